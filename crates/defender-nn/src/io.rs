//! Safetensors files: networks with PyTorch `nn.Sequential` names, and Adam state.
//!
//! A network's layer `l` is saved as `{2l}.weight` (`[out, in]`) and `{2l}.bias` (`[out]`), the
//! names of an `nn.Sequential(Linear, act, Linear, act, ..., Linear[, out_act])`, so PyTorch
//! loads the file with `model.load_state_dict(safetensors.torch.load_file(path))`. The widths
//! and activations are kept in the file's metadata (`defender.widths`, `defender.hidden`,
//! `defender.output`). Adam state goes into its own file: `{2l}.weight.exp_avg`,
//! `{2l}.weight.exp_avg_sq` (and the same for biases), with the step count and the
//! hyperparameters in the metadata. Values are stored bit for bit; writes are atomic
//! (temporary file, then rename).

use std::collections::HashMap;
use std::path::Path;

use safetensors::{Dtype, SafeTensors};

use crate::{Activation, Adam, AdamConfig, Mlp, NnError, Result};

const KEY_WIDTHS: &str = "defender.widths";
const KEY_HIDDEN: &str = "defender.hidden";
const KEY_OUTPUT: &str = "defender.output";
const KEY_STEP: &str = "defender.adam.step";
const KEY_LR: &str = "defender.adam.lr";
const KEY_BETA1: &str = "defender.adam.beta1";
const KEY_BETA2: &str = "defender.adam.beta2";
const KEY_EPS: &str = "defender.adam.eps";

/// One tensor to write: name, shape, values.
struct Entry<'a> {
    name: String,
    shape: Vec<usize>,
    values: &'a [f32],
}

/// The tensors of a parameter-shaped flat vector (params, grads or Adam moments), with names
/// `{2l}.weight{suffix}` / `{2l}.bias{suffix}`.
fn entries<'a>(mlp_slots: &[crate::mlp::LayerSlot], flat: &'a [f32], suffix: &str) -> Vec<Entry<'a>> {
    let mut out = Vec::with_capacity(2 * mlp_slots.len());
    for (l, s) in mlp_slots.iter().enumerate() {
        out.push(Entry {
            name: format!("{}.weight{suffix}", 2 * l),
            shape: vec![s.fan_out, s.fan_in],
            values: &flat[s.weight..s.bias],
        });
        out.push(Entry {
            name: format!("{}.bias{suffix}", 2 * l),
            shape: vec![s.fan_out],
            values: &flat[s.bias..s.bias + s.fan_out],
        });
    }
    out
}

fn write(path: &Path, entries: &[Entry<'_>], metadata: HashMap<String, String>) -> Result<()> {
    let bytes: Vec<Vec<u8>> =
        entries.iter().map(|e| e.values.iter().flat_map(|v| v.to_le_bytes()).collect()).collect();
    let mut views = Vec::with_capacity(entries.len());
    for (e, b) in entries.iter().zip(&bytes) {
        let view = safetensors::tensor::TensorView::new(Dtype::F32, e.shape.clone(), b)
            .map_err(|source| NnError::Format { path: path.to_path_buf(), source })?;
        views.push((e.name.clone(), view));
    }
    safetensors::serialize_to_file(views, Some(metadata), path).map_err(|source| match source {
        safetensors::SafeTensorError::IoError(source) => NnError::Io { path: path.to_path_buf(), source },
        source => NnError::Format { path: path.to_path_buf(), source },
    })
}

fn read_bytes(path: &Path) -> Result<Vec<u8>> {
    std::fs::read(path).map_err(|source| NnError::Io { path: path.to_path_buf(), source })
}

fn metadata(path: &Path, bytes: &[u8]) -> Result<HashMap<String, String>> {
    let (_, meta) = SafeTensors::read_metadata(bytes)
        .map_err(|source| NnError::Format { path: path.to_path_buf(), source })?;
    Ok(meta.metadata().clone().unwrap_or_default().into_iter().collect())
}

fn meta_get<'m>(
    path: &Path,
    meta: &'m HashMap<String, String>,
    key: &str,
    expected: &str,
) -> Result<&'m str> {
    meta.get(key).map(String::as_str).ok_or_else(|| NnError::Metadata {
        path: path.to_path_buf(),
        key: key.to_string(),
        expected: expected.to_string(),
        got: None,
    })
}

fn meta_parse<T: std::str::FromStr>(
    path: &Path,
    meta: &HashMap<String, String>,
    key: &str,
    expected: &str,
) -> Result<T> {
    let s = meta_get(path, meta, key, expected)?;
    s.parse().map_err(|_| NnError::Metadata {
        path: path.to_path_buf(),
        key: key.to_string(),
        expected: expected.to_string(),
        got: Some(s.to_string()),
    })
}

fn meta_activation(path: &Path, meta: &HashMap<String, String>, key: &str) -> Result<Activation> {
    let expected = "one of identity, relu, tanh";
    let s = meta_get(path, meta, key, expected)?;
    Activation::from_name(s).ok_or_else(|| NnError::Metadata {
        path: path.to_path_buf(),
        key: key.to_string(),
        expected: expected.to_string(),
        got: Some(s.to_string()),
    })
}

fn widths_string(widths: &[usize]) -> String {
    widths.iter().map(usize::to_string).collect::<Vec<_>>().join(",")
}

fn parse_widths(path: &Path, meta: &HashMap<String, String>) -> Result<Vec<usize>> {
    let expected = "comma-separated positive layer widths, e.g. 14,256,256,1";
    let s = meta_get(path, meta, KEY_WIDTHS, expected)?;
    let bad = || NnError::Metadata {
        path: path.to_path_buf(),
        key: KEY_WIDTHS.to_string(),
        expected: expected.to_string(),
        got: Some(s.to_string()),
    };
    s.split(',').map(|w| w.trim().parse::<usize>().map_err(|_| bad())).collect()
}

/// Fills the parameter-shaped `flat` from the tensors `{2l}.weight{suffix}`,
/// `{2l}.bias{suffix}` of `st`; every tensor of the file must be one of those.
fn fill(
    path: &Path,
    st: &SafeTensors<'_>,
    slots: &[crate::mlp::LayerSlot],
    suffixes: &[&str],
    flats: &mut [&mut [f32]],
) -> Result<()> {
    let mut expected_names = Vec::new();
    for (suffix, flat) in suffixes.iter().zip(flats.iter_mut()) {
        for (l, s) in slots.iter().enumerate() {
            let targets = [
                (format!("{}.weight{suffix}", 2 * l), vec![s.fan_out, s.fan_in], s.weight..s.bias),
                (format!("{}.bias{suffix}", 2 * l), vec![s.fan_out], s.bias..s.bias + s.fan_out),
            ];
            for (name, shape, range) in targets {
                expected_names.push(name.clone());
                let view = st.tensor(&name).map_err(|_| NnError::MissingTensor {
                    path: path.to_path_buf(),
                    name: name.clone(),
                    expected: shape.clone(),
                })?;
                if view.dtype() != Dtype::F32 {
                    return Err(NnError::TensorDtype {
                        path: path.to_path_buf(),
                        name,
                        got: format!("{:?}", view.dtype()),
                    });
                }
                if view.shape() != shape.as_slice() {
                    return Err(NnError::TensorShape {
                        path: path.to_path_buf(),
                        name,
                        expected: shape,
                        got: view.shape().to_vec(),
                    });
                }
                for (dst, src) in flat[range].iter_mut().zip(view.data().chunks_exact(4)) {
                    *dst = f32::from_le_bytes([src[0], src[1], src[2], src[3]]);
                }
            }
        }
    }
    for name in st.names() {
        if !expected_names.iter().any(|e| e == name) {
            let described = match expected_names.len() {
                0..=6 => expected_names.join(", "),
                n => format!("{}, ... ({n} tensors)", expected_names[..4].join(", ")),
            };
            return Err(NnError::UnexpectedTensor {
                path: path.to_path_buf(),
                name: name.to_string(),
                expected: described,
            });
        }
    }
    Ok(())
}

fn deserialize<'b>(path: &Path, bytes: &'b [u8]) -> Result<SafeTensors<'b>> {
    SafeTensors::deserialize(bytes).map_err(|source| NnError::Format { path: path.to_path_buf(), source })
}

impl Mlp {
    /// Saves the parameters with PyTorch `nn.Sequential` names (`0.weight`, `0.bias`,
    /// `2.weight`, ...; weights `[out, in]`), plus widths and activations as metadata.
    ///
    /// # Errors
    ///
    /// [`NnError::Io`] if the file cannot be written.
    pub fn save_safetensors(&self, path: impl AsRef<Path>) -> Result<()> {
        let path = path.as_ref();
        let meta = HashMap::from([
            ("format".to_string(), "pt".to_string()),
            (KEY_WIDTHS.to_string(), widths_string(self.widths())),
            (KEY_HIDDEN.to_string(), self.hidden_activation().name().to_string()),
            (KEY_OUTPUT.to_string(), self.output_activation().name().to_string()),
        ]);
        write(path, &entries(self.slots(), self.params(), ""), meta)
    }

    /// Loads a network saved by [`Mlp::save_safetensors`] (widths and activations from the
    /// metadata). For a file written by PyTorch, build the network with [`Mlp::zeros`] and use
    /// [`Mlp::load_params_safetensors`].
    ///
    /// # Errors
    ///
    /// [`NnError::Io`], [`NnError::Format`], [`NnError::Metadata`] (missing or bad widths or
    /// activations), and the tensor errors of [`Mlp::load_params_safetensors`].
    pub fn load_safetensors(path: impl AsRef<Path>) -> Result<Mlp> {
        let path = path.as_ref();
        let bytes = read_bytes(path)?;
        let meta = metadata(path, &bytes)?;
        let widths = parse_widths(path, &meta)?;
        let hidden = meta_activation(path, &meta, KEY_HIDDEN)?;
        let output = meta_activation(path, &meta, KEY_OUTPUT)?;
        let mut mlp = Mlp::zeros(&widths, hidden, output).map_err(|e| NnError::Metadata {
            path: path.to_path_buf(),
            key: KEY_WIDTHS.to_string(),
            expected: format!("valid widths ({e})"),
            got: Some(widths_string(&widths)),
        })?;
        mlp.read_params(path, &bytes)?;
        Ok(mlp)
    }

    /// Overwrites this network's parameters from a safetensors file with PyTorch
    /// `nn.Sequential` names and shapes (`{2l}.weight` `[out, in]`, `{2l}.bias` `[out]`, f32),
    /// e.g. `safetensors.torch.save_file(model.state_dict(), path)`. Metadata is ignored. On
    /// error the parameters are unchanged.
    ///
    /// # Errors
    ///
    /// [`NnError::Io`], [`NnError::Format`], [`NnError::MissingTensor`],
    /// [`NnError::TensorShape`], [`NnError::TensorDtype`], [`NnError::UnexpectedTensor`].
    pub fn load_params_safetensors(&mut self, path: impl AsRef<Path>) -> Result<()> {
        let path = path.as_ref();
        let bytes = read_bytes(path)?;
        self.read_params(path, &bytes)
    }

    fn read_params(&mut self, path: &Path, bytes: &[u8]) -> Result<()> {
        let st = deserialize(path, bytes)?;
        let mut params = vec![0.0f32; self.num_params()];
        let slots = self.slots().to_vec();
        fill(path, &st, &slots, &[""], &mut [&mut params])?;
        self.params_mut().copy_from_slice(&params);
        Ok(())
    }
}

impl Adam {
    /// Saves the optimiser state (moments, step count, hyperparameters) for checkpoint and
    /// resume; [`Adam::load_safetensors`] restores it bit for bit.
    ///
    /// # Errors
    ///
    /// [`NnError::Io`] if the file cannot be written.
    pub fn save_safetensors(&self, path: impl AsRef<Path>) -> Result<()> {
        let path = path.as_ref();
        // A stand-in network gives the layer slots; it costs one allocation at save time.
        let shape = Mlp::zeros(&self.widths, Activation::Identity, Activation::Identity).map_err(|e| {
            NnError::Metadata {
                path: path.to_path_buf(),
                key: KEY_WIDTHS.to_string(),
                expected: format!("valid widths ({e})"),
                got: Some(widths_string(&self.widths)),
            }
        })?;
        let mut all = entries(shape.slots(), &self.exp_avg, ".exp_avg");
        all.extend(entries(shape.slots(), &self.exp_avg_sq, ".exp_avg_sq"));
        // Rust prints f32 with the shortest text that parses back to the same value.
        let meta = HashMap::from([
            (KEY_WIDTHS.to_string(), widths_string(&self.widths)),
            (KEY_STEP.to_string(), self.step.to_string()),
            (KEY_LR.to_string(), self.config.lr.to_string()),
            (KEY_BETA1.to_string(), self.config.beta1.to_string()),
            (KEY_BETA2.to_string(), self.config.beta2.to_string()),
            (KEY_EPS.to_string(), self.config.eps.to_string()),
        ]);
        write(path, &all, meta)
    }

    /// Loads optimiser state saved by [`Adam::save_safetensors`] for the network `mlp`
    /// (whose widths it must match).
    ///
    /// # Errors
    ///
    /// [`NnError::Io`], [`NnError::Format`], [`NnError::Metadata`] (missing step or
    /// hyperparameters, or widths other than `mlp`'s), [`NnError::MissingTensor`],
    /// [`NnError::TensorShape`], [`NnError::TensorDtype`], [`NnError::UnexpectedTensor`].
    pub fn load_safetensors(path: impl AsRef<Path>, mlp: &Mlp) -> Result<Adam> {
        let path = path.as_ref();
        let bytes = read_bytes(path)?;
        let meta = metadata(path, &bytes)?;
        let widths = parse_widths(path, &meta)?;
        if widths != mlp.widths() {
            return Err(NnError::Metadata {
                path: path.to_path_buf(),
                key: KEY_WIDTHS.to_string(),
                expected: format!("the network's widths {}", widths_string(mlp.widths())),
                got: Some(widths_string(&widths)),
            });
        }
        let number = "a number";
        let config = AdamConfig {
            lr: meta_parse(path, &meta, KEY_LR, number)?,
            beta1: meta_parse(path, &meta, KEY_BETA1, number)?,
            beta2: meta_parse(path, &meta, KEY_BETA2, number)?,
            eps: meta_parse(path, &meta, KEY_EPS, number)?,
        };
        let step = meta_parse(path, &meta, KEY_STEP, "a non-negative integer")?;
        let st = deserialize(path, &bytes)?;
        let n = mlp.num_params();
        let (mut m, mut v) = (vec![0.0f32; n], vec![0.0f32; n]);
        fill(path, &st, mlp.slots(), &[".exp_avg", ".exp_avg_sq"], &mut [&mut m, &mut v])?;
        Ok(Adam { config, step, exp_avg: m, exp_avg_sq: v, widths })
    }
}
