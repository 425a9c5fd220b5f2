//! NumPy `.npy` arrays of float32 or float16 (little-endian, C order), read as float32: the
//! feature maps and per-Gaussian feature sidecars of stage 1, and phrase embeddings.

use std::path::Path;

/// An array read from `.npy`: its shape and its values in C order.
#[derive(Debug, Clone, PartialEq)]
pub struct NpyF32 {
    /// The shape, outermost first.
    pub shape: Vec<usize>,
    /// The values, row-major.
    pub values: Vec<f32>,
}

/// Reads a float32 or float16 `.npy` file.
///
/// # Errors
/// A message saying what is wrong (unreadable, not `.npy`, Fortran order, another dtype); the
/// caller adds the path.
pub fn read_npy_f32(path: &Path) -> Result<NpyF32, String> {
    let bytes = std::fs::read(path).map_err(|e| e.to_string())?;
    let npy = npyz::NpyFile::new(&bytes[..]).map_err(|e| e.to_string())?;
    let shape: Vec<usize> = npy.shape().iter().map(|&s| s as usize).collect();
    if npy.order() != npyz::Order::C {
        return Err(format!(
            "Fortran-order array (shape {shape:?}); save it in C order"
        ));
    }
    let type_str = match npy.dtype() {
        npyz::DType::Plain(t) => t.to_string(),
        other => return Err(format!("dtype {} is not a plain float", other.descr())),
    };
    let values: Vec<f32> = match type_str.as_str() {
        "<f4" => npy.into_vec::<f32>().map_err(|e| e.to_string())?,
        "<f2" => npy
            .into_vec::<npyz::half::f16>()
            .map_err(|e| e.to_string())?
            .into_iter()
            .map(f32::from)
            .collect(),
        other => {
            return Err(format!(
                "dtype {other} not supported (little-endian float32 or float16)"
            ));
        }
    };
    Ok(NpyF32 { shape, values })
}
