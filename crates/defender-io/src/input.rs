//! Opening a user's input file: only a regular file is read. A device (`/dev/zero` never ends),
//! a FIFO (`open` blocks until a writer comes) or a directory is refused at once, naming the
//! path and what it is, before anything waits on it.

use std::fs::{File, FileType};
use std::io::{self, Read};
use std::os::unix::fs::FileTypeExt;
use std::path::Path;

/// What a file type is, in a user's words.
fn kind(t: FileType) -> &'static str {
    if t.is_dir() {
        "a directory"
    } else if t.is_fifo() {
        "a FIFO (named pipe)"
    } else if t.is_char_device() {
        "a character device"
    } else if t.is_block_device() {
        "a block device"
    } else if t.is_socket() {
        "a socket"
    } else {
        "not a regular file"
    }
}

fn refuse(t: FileType) -> io::Error {
    io::Error::new(
        io::ErrorKind::InvalidInput,
        format!("is {}, not a regular file (only a file is read as input)", kind(t)),
    )
}

/// Checks that `path` names a regular file (symbolic links followed), without opening it.
///
/// # Errors
/// The file's absence or unreadable metadata, or [`io::ErrorKind::InvalidInput`] saying what it
/// is when it is not a regular file (the caller names the path, as for any I/O error).
pub fn check_regular(path: &Path) -> io::Result<()> {
    let t = std::fs::metadata(path)?.file_type();
    if t.is_file() { Ok(()) } else { Err(refuse(t)) }
}

/// Opens `path` for reading if it is a regular file (checked before opening, so a FIFO never
/// blocks, and again on the open file).
///
/// # Errors
/// As [`check_regular`], or the error of opening it.
pub fn open_input(path: &Path) -> io::Result<File> {
    check_regular(path)?;
    let file = File::open(path)?;
    let t = file.metadata()?.file_type();
    if t.is_file() { Ok(file) } else { Err(refuse(t)) }
}

/// Reads a regular file whole (as [`std::fs::read`], refusing what [`open_input`] refuses).
///
/// # Errors
/// As [`open_input`], or the error of reading it.
pub fn read_input(path: &Path) -> io::Result<Vec<u8>> {
    let mut bytes = Vec::new();
    open_input(path)?.read_to_end(&mut bytes)?;
    Ok(bytes)
}

/// Reads a regular file whole as UTF-8 text (as [`std::fs::read_to_string`], refusing what
/// [`open_input`] refuses).
///
/// # Errors
/// As [`open_input`], or the error of reading it.
pub fn read_input_to_string(path: &Path) -> io::Result<String> {
    let mut text = String::new();
    open_input(path)?.read_to_string(&mut text)?;
    Ok(text)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn only_regular_files_are_read() {
        let dir = tempfile::tempdir().unwrap();
        let file = dir.path().join("a.toml");
        std::fs::write(&file, "x = 1\n").unwrap();
        assert_eq!(read_input_to_string(&file).unwrap(), "x = 1\n");
        for (path, what) in [(dir.path(), "a directory"), (Path::new("/dev/zero"), "a character device")] {
            let e = open_input(path).unwrap_err();
            assert_eq!(e.kind(), io::ErrorKind::InvalidInput);
            assert!(e.to_string().contains(what), "{e}");
        }
        let fifo = dir.path().join("fifo");
        assert!(std::process::Command::new("mkfifo").arg(&fifo).status().unwrap().success());
        let e = open_input(&fifo).unwrap_err();
        assert!(e.to_string().contains("FIFO"), "{e}");
        assert_eq!(open_input(&dir.path().join("none")).unwrap_err().kind(), io::ErrorKind::NotFound);
    }
}
