//! Training cameras: the same camera written as transforms.json (OpenGL camera-to-world), COLMAP
//! text and COLMAP binary (OpenCV world-to-camera) must read back as the rasterizer's own view
//! of it, and malformed files name the line or byte that is wrong.

use glam::{Mat3, Quat, Vec3};
use splatphys_render::Camera;
use splatphys_render::camera::ViewParams;
use splatphys_stage1::read_cameras;

fn camera() -> (Camera, ViewParams) {
    let cam = Camera::new(
        Vec3::new(0.7, -1.2, 0.5),
        Vec3::new(0.05, 0.1, -0.02),
        Vec3::Z,
        40.0,
        320,
        240,
    )
    .unwrap();
    (cam, cam.view_params().unwrap())
}

fn assert_same(a: &ViewParams, b: &ViewParams) {
    let close = |x: f32, y: f32, tol: f32| (x - y).abs() <= tol * (1.0 + y.abs());
    for (x, y) in a
        .rotation
        .to_cols_array()
        .iter()
        .zip(b.rotation.to_cols_array())
    {
        assert!(
            close(*x, y, 1e-5),
            "rotation {:?} vs {:?}",
            a.rotation,
            b.rotation
        );
    }
    assert!((a.position - b.position).length() < 1e-5, "{a:?} vs {b:?}");
    for i in 0..2 {
        assert!(close(a.focal_px[i], b.focal_px[i], 1e-5), "{a:?} vs {b:?}");
        assert!(
            close(a.principal_px[i], b.principal_px[i], 1e-5),
            "{a:?} vs {b:?}"
        );
        assert!(
            close(a.tan_half_fov[i], b.tan_half_fov[i], 1e-5),
            "{a:?} vs {b:?}"
        );
    }
    assert_eq!(a.size_px, b.size_px);
    // And a point lands on the same pixel.
    let p = Vec3::new(0.1, 0.0, 0.05);
    let (pa, pb) = (a.to_pixel(a.to_view(p)), b.to_pixel(b.to_view(p)));
    assert!((pa[0] - pb[0]).abs() < 1e-3 && (pa[1] - pb[1]).abs() < 1e-3);
}

#[test]
fn transforms_json_reads_as_the_same_camera() {
    let (cam, want) = camera();
    let w = want.rotation.transpose(); // columns: right, down, forward
    let (right, down, forward) = (w.x_axis, w.y_axis, w.z_axis);
    let cols = [right, -down, -forward, cam.position];
    let rows: Vec<Vec<f32>> = (0..3)
        .map(|r| cols.iter().map(|c| c[r]).collect())
        .chain([vec![0.0, 0.0, 0.0, 1.0]])
        .collect();
    let json = serde_json::json!({
        "camera_angle_x": 2.0 * (want.tan_half_fov[0]).atan(),
        "fl_y": want.focal_px[1],
        "w": 320, "h": 240,
        "frames": [{ "file_path": "./train/r_7", "transform_matrix": rows }],
    });
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("transforms.json");
    std::fs::write(&path, json.to_string()).unwrap();
    let set = read_cameras(&path, None).unwrap();
    assert_eq!(set.views.len(), 1);
    assert_eq!(set.views[0].name, "r_7");
    assert_same(&set.views[0].view, &want);
}

fn colmap_pose(want: &ViewParams) -> ([f64; 4], [f64; 3]) {
    let q = Quat::from_mat3(&want.rotation);
    let t = -(want.rotation * want.position);
    (
        [q.w, q.x, q.y, q.z].map(f64::from),
        t.to_array().map(f64::from),
    )
}

#[test]
fn colmap_text_and_binary_read_as_the_same_camera() {
    let (_, want) = camera();
    let (q, t) = colmap_pose(&want);
    let (f, cx, cy) = (
        f64::from(want.focal_px[0]),
        f64::from(want.principal_px[0]) + 0.5,
        f64::from(want.principal_px[1]) + 0.5,
    );
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(
        dir.path().join("cameras.txt"),
        format!("# Camera list\n3 PINHOLE 320 240 {f} {f} {cx} {cy}\n"),
    )
    .unwrap();
    std::fs::write(
        dir.path().join("images.txt"),
        format!(
            "# Image list\n# comment\n1 {} {} {} {} {} {} {} 3 my image 1.png\n\n2 1 0 0 0 0 0 0 3 other.png\n10.0 20.0 -1\n",
            q[0], q[1], q[2], q[3], t[0], t[1], t[2]
        ),
    )
    .unwrap();
    let set = read_cameras(dir.path(), None).unwrap();
    assert_eq!(set.views.len(), 2);
    assert_eq!(set.views[0].name, "my image 1");
    assert_eq!(set.views[1].name, "other");
    assert_eq!(set.views[1].view.rotation, Mat3::IDENTITY);
    assert_same(&set.views[0].view, &want);
    assert!(set.warnings.is_empty());

    // The same model in binary, under sparse/0.
    let bin = dir.path().join("bin");
    let sparse = bin.join("sparse").join("0");
    std::fs::create_dir_all(&sparse).unwrap();
    let mut cams = Vec::new();
    cams.extend(1u64.to_le_bytes());
    cams.extend(3i32.to_le_bytes());
    cams.extend(1i32.to_le_bytes()); // PINHOLE
    cams.extend(320u64.to_le_bytes());
    cams.extend(240u64.to_le_bytes());
    for v in [f, f, cx, cy] {
        cams.extend(v.to_le_bytes());
    }
    std::fs::write(sparse.join("cameras.bin"), &cams).unwrap();
    let mut imgs = Vec::new();
    imgs.extend(1u64.to_le_bytes());
    imgs.extend(1i32.to_le_bytes());
    for v in q.iter().chain(&t) {
        imgs.extend(v.to_le_bytes());
    }
    imgs.extend(3i32.to_le_bytes());
    imgs.extend(b"frame_0001.jpg\0");
    imgs.extend(2u64.to_le_bytes());
    for _ in 0..2 {
        imgs.extend(1.5f64.to_le_bytes());
        imgs.extend(2.5f64.to_le_bytes());
        imgs.extend((-1i64).to_le_bytes());
    }
    std::fs::write(sparse.join("images.bin"), &imgs).unwrap();
    let set = read_cameras(&bin, None).unwrap();
    assert_eq!(set.views.len(), 1);
    assert_eq!(set.views[0].name, "frame_0001");
    assert_same(&set.views[0].view, &want);

    // Truncated binary: the byte offset is named.
    std::fs::write(sparse.join("images.bin"), &imgs[..40]).unwrap();
    let err = read_cameras(&bin, None).unwrap_err().to_string();
    assert!(
        err.contains("images.bin") && err.contains("truncated at byte"),
        "{err}"
    );
}

#[test]
fn malformed_colmap_files_name_the_line() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(
        dir.path().join("cameras.txt"),
        "1 OPENCV_FISHEYE 100 100 50 50 50 50 0 0 0 0\n",
    )
    .unwrap();
    std::fs::write(dir.path().join("images.txt"), "").unwrap();
    let err = read_cameras(dir.path(), None).unwrap_err().to_string();
    assert!(err.contains("line 1") && err.contains("fisheye"), "{err}");

    std::fs::write(
        dir.path().join("cameras.txt"),
        "1 SIMPLE_RADIAL 100 80 60 50 40 0.01\n",
    )
    .unwrap();
    std::fs::write(
        dir.path().join("images.txt"),
        "# header\n1 1 0 0 0 0 0 x 1 a.png\n\n",
    )
    .unwrap();
    let err = read_cameras(dir.path(), None).unwrap_err().to_string();
    assert!(err.contains("line 2") && err.contains("\"x\""), "{err}");

    std::fs::write(dir.path().join("images.txt"), "1 1 0 0 0 0 0 1 7 a.png\n\n").unwrap();
    let err = read_cameras(dir.path(), None).unwrap_err().to_string();
    assert!(err.contains("camera 7"), "{err}");

    std::fs::write(dir.path().join("images.txt"), "1 1 0 0 0 0 0 1 1 a.png\n\n").unwrap();
    let set = read_cameras(dir.path(), None).unwrap();
    assert_eq!(set.warnings.len(), 1, "{:?}", set.warnings);
    assert!(set.warnings[0].contains("SIMPLE_RADIAL"));

    let err = read_cameras(&dir.path().join("nothing"), None)
        .unwrap_err()
        .to_string();
    assert!(err.contains("not a transforms.json"), "{err}");
}

#[test]
fn transforms_json_without_size_needs_an_image_or_a_size() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("transforms.json");
    let eye = [
        [1.0, 0.0, 0.0, 0.0],
        [0.0, 1.0, 0.0, 0.0],
        [0.0, 0.0, 1.0, 2.0],
        [0.0, 0.0, 0.0, 1.0],
    ];
    let json = serde_json::json!({
        "camera_angle_x": 0.69,
        "frames": [{ "file_path": "./train/r_0", "transform_matrix": eye }],
    });
    std::fs::write(&path, json.to_string()).unwrap();
    let err = read_cameras(&path, None).unwrap_err().to_string();
    assert!(
        err.contains("frames[0]") && err.contains("--image-size"),
        "{err}"
    );
    let set = read_cameras(&path, Some([800, 800])).unwrap();
    assert_eq!(set.views[0].view.size_px, [800, 800]);
    // fx = 400 / tan(0.345).
    let fx = 400.0 / 0.345f32.tan();
    assert!((set.views[0].view.focal_px[0] - fx).abs() < 1e-2 * fx);
    // Looking down -z from z = 2: the origin projects to the image centre.
    let v = set.views[0].view;
    let px = v.to_pixel(v.to_view(Vec3::ZERO));
    assert!(
        (px[0] - 399.5).abs() < 1e-3 && (px[1] - 399.5).abs() < 1e-3,
        "{px:?}"
    );
}
