//! `.npy` reading for features and embeddings: float32 and float16 round trips through a writer
//! that is not ours (npyz), and clear errors for other dtypes and shapes. (A dtype comparison
//! against the quoted `descr()` string once refused every file.)

use npyz::WriterBuilder;
use splatphys_core::formats::npy::read_npy_f32;
use splatphys_core::selection::semantic::read_npy_matrix;

fn write<T: npyz::AutoSerialize + Copy>(path: &std::path::Path, shape: &[u64], values: &[T]) {
    let mut file = std::fs::File::create(path).unwrap();
    let mut w = npyz::WriteOptions::new()
        .default_dtype()
        .shape(shape)
        .writer(&mut file)
        .begin_nd()
        .unwrap();
    w.extend(values.iter().copied()).unwrap();
    w.finish().unwrap();
}

#[test]
fn float32_and_float16_matrices_round_trip() {
    let dir = tempfile::tempdir().unwrap();
    let values = [0.5f32, -1.25, 3.0, 1e-3, 7.0, -0.0];
    let p32 = dir.path().join("a.npy");
    write(&p32, &[2, 3], &values);
    assert_eq!(read_npy_matrix(&p32).unwrap(), (values.to_vec(), 3));

    let p16 = dir.path().join("b.npy");
    let halves: Vec<npyz::half::f16> = values
        .iter()
        .map(|&v| npyz::half::f16::from_f32(v))
        .collect();
    write(&p16, &[3, 2], &halves);
    let (read, dim) = read_npy_matrix(&p16).unwrap();
    assert_eq!(dim, 2);
    for (r, v) in read.iter().zip(values) {
        assert!((r - v).abs() <= 1e-3 * v.abs().max(1.0), "{r} vs {v}");
    }

    let p3 = dir.path().join("c.npy");
    write(&p3, &[1, 2, 3], &values);
    assert_eq!(read_npy_f32(&p3).unwrap().shape, vec![1, 2, 3]);
    let err = read_npy_matrix(&p3).unwrap_err().to_string();
    assert!(err.contains("c.npy") && err.contains("2-D"), "{err}");
}

#[test]
fn other_dtypes_are_refused_by_name() {
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path().join("ints.npy");
    write(&p, &[2, 2], &[1i32, 2, 3, 4]);
    let err = read_npy_matrix(&p).unwrap_err().to_string();
    assert!(err.contains("ints.npy") && err.contains("<i4"), "{err}");
}
