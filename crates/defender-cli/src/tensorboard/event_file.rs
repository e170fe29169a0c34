//! TensorBoard's event file: a TFRecord stream of `tensorflow.Event` protocol buffers, of which
//! defender writes the two kinds scalars need (the file version, then summaries of
//! `simple_value`s). The messages are declared with `prost`'s derive (the few fields used, with
//! TensorFlow's field numbers from `tensorflow/core/util/event.proto` and
//! `tensorflow/core/framework/summary.proto`); each record is framed as TFRecord does: the
//! length (u64, little-endian), its masked CRC-32C, the bytes, their masked CRC-32C.
//!
//! A file is appended to as training goes and flushed about every second (see `board`), so a run can be
//! watched live; [`EventFile::offset`] is the length of what has been written, which a checkpoint
//! records so that a resumed run truncates what came after it (docs/decisions-python.md).

use std::fs::{File, OpenOptions};
use std::io::{BufWriter, Write};
use std::path::{Path, PathBuf};

use anyhow::{Context, Result, bail};
use prost::Message;

/// `tensorflow.Event` (the fields used).
#[derive(Clone, PartialEq, prost::Message)]
struct Event {
    #[prost(double, tag = "1")]
    wall_time: f64,
    #[prost(int64, tag = "2")]
    step: i64,
    #[prost(oneof = "What", tags = "3, 5")]
    what: Option<What>,
}

/// The `what` of an event.
#[derive(Clone, PartialEq, prost::Oneof)]
enum What {
    #[prost(string, tag = "3")]
    FileVersion(String),
    #[prost(message, tag = "5")]
    Summary(Summary),
}

/// `tensorflow.Summary`.
#[derive(Clone, PartialEq, prost::Message)]
struct Summary {
    #[prost(message, repeated, tag = "1")]
    value: Vec<SummaryValue>,
}

/// `tensorflow.Summary.Value` with a `simple_value` (the scalar TensorBoard's scalars plugin
/// reads). `optional` so that a value of 0 is written rather than left out as proto3 defaults are.
#[derive(Clone, PartialEq, prost::Message)]
struct SummaryValue {
    #[prost(string, tag = "1")]
    tag: String,
    #[prost(float, optional, tag = "2")]
    simple_value: Option<f32>,
}

/// The version string TensorBoard expects in the first event.
const FILE_VERSION: &str = "brain.Event:2";

/// TFRecord's masked CRC-32C.
fn masked_crc(bytes: &[u8]) -> u32 {
    let crc = crc32c::crc32c(bytes);
    (crc.rotate_right(15)).wrapping_add(0xa282_ead8)
}

/// Seconds since the Unix epoch, as TensorBoard's `wall_time`.
pub fn now() -> f64 {
    std::time::SystemTime::now().duration_since(std::time::UNIX_EPOCH).map_or(0.0, |d| d.as_secs_f64())
}

/// An event file being written.
pub struct EventFile {
    path: PathBuf,
    out: BufWriter<File>,
    offset: u64,
    buf: Vec<u8>,
}

impl EventFile {
    /// A file name TensorBoard recognises (`events.out.tfevents.` + a time + a name), unique for
    /// a run started at `wall_time`.
    pub fn file_name(wall_time: f64, host: &str) -> String {
        format!("events.out.tfevents.{}.{host}", wall_time as u64)
    }

    /// Creates (or replaces) `path` with its first event, the file version.
    ///
    /// # Errors
    /// The file cannot be written.
    pub fn create(path: &Path, wall_time: f64) -> Result<Self> {
        let file = File::create(path).with_context(|| format!("cannot create {}", path.display()))?;
        let mut this =
            Self { path: path.to_path_buf(), out: BufWriter::new(file), offset: 0, buf: Vec::new() };
        this.write(&Event { wall_time, step: 0, what: Some(What::FileVersion(FILE_VERSION.into())) })?;
        Ok(this)
    }

    /// Opens `path` to append after its first `offset` bytes, dropping whatever follows them
    /// (events written after the checkpoint that recorded `offset`).
    ///
    /// # Errors
    /// The file cannot be opened, or is shorter than `offset` (then it is not the file the
    /// checkpoint recorded).
    pub fn truncate_to(path: &Path, offset: u64) -> Result<Self> {
        let file = OpenOptions::new()
            .read(true)
            .write(true)
            .open(path)
            .with_context(|| format!("cannot open {}", path.display()))?;
        let len = file.metadata().with_context(|| format!("cannot read {}", path.display()))?.len();
        if len < offset {
            bail!("{}: {len} bytes, shorter than the {offset} its checkpoint recorded", path.display());
        }
        file.set_len(offset).with_context(|| format!("cannot truncate {}", path.display()))?;
        let mut file = file;
        std::io::Seek::seek(&mut file, std::io::SeekFrom::Start(offset))
            .with_context(|| format!("cannot seek in {}", path.display()))?;
        Ok(Self { path: path.to_path_buf(), out: BufWriter::new(file), offset, buf: Vec::new() })
    }

    /// The file.
    pub fn path(&self) -> &Path {
        &self.path
    }

    /// Bytes written so far (flushed or buffered).
    pub fn offset(&self) -> u64 {
        self.offset
    }

    /// Writes one event holding `values` as scalars at `step` (non-finite values included:
    /// TensorBoard shows NaN and infinities as such).
    ///
    /// # Errors
    /// The file cannot be written.
    pub fn scalars(&mut self, step: u64, wall_time: f64, values: &[(&str, f64)]) -> Result<()> {
        if values.is_empty() {
            return Ok(());
        }
        let value = values
            .iter()
            .map(|&(tag, v)| SummaryValue { tag: tag.to_string(), simple_value: Some(v as f32) })
            .collect();
        let step = i64::try_from(step).unwrap_or(i64::MAX);
        self.write(&Event { wall_time, step, what: Some(What::Summary(Summary { value })) })
    }

    fn write(&mut self, event: &Event) -> Result<()> {
        self.buf.clear();
        event.encode(&mut self.buf).context("cannot encode a TensorBoard event")?;
        let len = (self.buf.len() as u64).to_le_bytes();
        let res = self
            .out
            .write_all(&len)
            .and_then(|()| self.out.write_all(&masked_crc(&len).to_le_bytes()))
            .and_then(|()| self.out.write_all(&self.buf))
            .and_then(|()| self.out.write_all(&masked_crc(&self.buf).to_le_bytes()));
        res.with_context(|| format!("cannot write {}", self.path.display()))?;
        self.offset += 16 + self.buf.len() as u64;
        Ok(())
    }

    /// Writes what is buffered to the file (the operating system's), so that TensorBoard sees it.
    ///
    /// # Errors
    /// The file cannot be written.
    pub fn flush(&mut self) -> Result<()> {
        self.out.flush().with_context(|| format!("cannot write {}", self.path.display()))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Every record's length and payload check against their masked CRC-32C, and the events
    /// decode back (TensorBoard's own reader reads these files in python/tests).
    #[test]
    fn records_are_framed_as_tfrecord() {
        // crc32c of b"123456789" is 0xe3069283 (the CRC-32C check value).
        assert_eq!(crc32c::crc32c(b"123456789"), 0xe306_9283);
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join(EventFile::file_name(1.0, "t"));
        let mut file = EventFile::create(&path, 1.0).unwrap();
        file.scalars(7, 2.0, &[("a", 0.0), ("b", 1.5)]).unwrap();
        file.flush().unwrap();
        let bytes = std::fs::read(&path).unwrap();
        assert_eq!(bytes.len() as u64, file.offset());
        // Walk the records: each length and payload checks against its CRC.
        let mut at = 0;
        let mut events = Vec::new();
        while at < bytes.len() {
            let len = u64::from_le_bytes(bytes[at..at + 8].try_into().unwrap()) as usize;
            let crc = u32::from_le_bytes(bytes[at + 8..at + 12].try_into().unwrap());
            assert_eq!(crc, masked_crc(&bytes[at..at + 8]));
            let data = &bytes[at + 12..at + 12 + len];
            let crc = u32::from_le_bytes(bytes[at + 12 + len..at + 16 + len].try_into().unwrap());
            assert_eq!(crc, masked_crc(data));
            events.push(Event::decode(data).unwrap());
            at += 16 + len;
        }
        assert_eq!(events.len(), 2);
        assert_eq!(events[0].what, Some(What::FileVersion(FILE_VERSION.into())));
        let Some(What::Summary(s)) = &events[1].what else { panic!("{:?}", events[1]) };
        assert_eq!(events[1].step, 7);
        // A zero is written, not left out.
        assert_eq!(s.value[0].simple_value, Some(0.0));
        assert_eq!(s.value[1].tag, "b");
    }

    #[test]
    fn truncating_drops_what_followed_the_offset() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("events.out.tfevents.1.t");
        let mut file = EventFile::create(&path, 1.0).unwrap();
        file.scalars(1, 1.0, &[("a", 1.0)]).unwrap();
        file.flush().unwrap();
        let kept = file.offset();
        file.scalars(2, 1.0, &[("a", 2.0)]).unwrap();
        file.flush().unwrap();
        drop(file);
        let mut file = EventFile::truncate_to(&path, kept).unwrap();
        assert_eq!(std::fs::metadata(&path).unwrap().len(), kept);
        file.scalars(2, 1.0, &[("a", 3.0)]).unwrap();
        file.flush().unwrap();
        assert_eq!(std::fs::metadata(&path).unwrap().len(), file.offset());
        let err = EventFile::truncate_to(&path, file.offset() + 1).err().unwrap().to_string();
        assert!(err.contains("shorter"), "{err}");
    }
}
