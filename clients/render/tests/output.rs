//! PNG and GIF files read back with what was written; MP4 only when ffmpeg is on PATH. Camera
//! helpers: framing keeps the whole box in view, orbits circle the centre.

mod common;

use glam::Vec3;
use splatphys_render::output::ffmpeg_available;
use splatphys_render::{
    Bounds, ImageRgb8, OrbitPath, OutputError, write_gif, write_mp4, write_png,
};

fn gradient(w: u32, h: u32, shift: u8) -> ImageRgb8 {
    let mut data = Vec::new();
    for y in 0..h {
        for x in 0..w {
            data.extend([(x * 8) as u8, (y * 8) as u8, shift]);
        }
    }
    ImageRgb8 {
        width: w,
        height: h,
        data,
    }
}

#[test]
fn png_round_trips_exactly() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("f.png");
    let img = gradient(20, 10, 7);
    write_png(&path, &img).unwrap();
    let back = image::open(&path).unwrap().to_rgb8();
    assert_eq!((back.width(), back.height()), (20, 10));
    assert_eq!(back.into_raw(), img.data);
}

#[test]
fn gif_has_every_frame_at_the_right_size() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("a.gif");
    let frames: Vec<ImageRgb8> = (0..4).map(|i| gradient(16, 12, 60 * i)).collect();
    write_gif(&path, &frames, 10.0).unwrap();
    use image::AnimationDecoder;
    let file = std::io::BufReader::new(std::fs::File::open(&path).unwrap());
    let decoded = image::codecs::gif::GifDecoder::new(file)
        .unwrap()
        .into_frames()
        .collect_frames()
        .unwrap();
    assert_eq!(decoded.len(), 4);
    for (frame, original) in decoded.iter().zip(&frames) {
        let buf = frame.buffer();
        assert_eq!(buf.dimensions(), (16, 12));
        // Palette quantisation: colours close to the original (blue channel identifies frames).
        let px = buf.get_pixel(5, 5).0;
        assert!(
            (i32::from(px[2]) - i32::from(original.data[2])).abs() <= 12,
            "{px:?}"
        );
    }
}

#[test]
fn animations_refuse_bad_sequences() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("a.gif");
    assert!(matches!(
        write_gif(&path, &[], 10.0),
        Err(OutputError::NoFrames { .. })
    ));
    let frames = [gradient(8, 8, 0), gradient(9, 8, 0)];
    assert!(matches!(
        write_gif(&path, &frames, 10.0),
        Err(OutputError::FrameSize { .. })
    ));
    assert!(matches!(
        write_gif(&path, &frames[..1], 0.0),
        Err(OutputError::FrameRate { .. })
    ));
    let empty = ImageRgb8 {
        width: 0,
        height: 0,
        data: Vec::new(),
    };
    assert!(matches!(
        write_png(&path, &empty),
        Err(OutputError::BadFrame { .. })
    ));
}

#[test]
fn mp4_is_written_only_when_ffmpeg_exists() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("a.mp4");
    let frames: Vec<ImageRgb8> = (0..3).map(|i| gradient(15, 9, 80 * i)).collect();
    let written = write_mp4(&path, &frames, 10.0).unwrap();
    assert_eq!(written, ffmpeg_available());
    assert_eq!(path.exists(), written);
}

#[test]
fn framing_keeps_every_corner_in_view() {
    let bounds = Bounds {
        min: Vec3::new(-0.1, -2.0, 0.0),
        max: Vec3::new(0.3, 0.4, 0.5),
    };
    for dir in [Vec3::X, Vec3::new(1.0, -1.0, 0.6), Vec3::NEG_Y] {
        let cam = bounds.frame(dir, Vec3::Z, 50.0, 320, 180).unwrap();
        let view = cam.view_params().unwrap();
        for i in 0..8 {
            let corner = Vec3::new(
                if i & 1 == 0 {
                    bounds.min.x
                } else {
                    bounds.max.x
                },
                if i & 2 == 0 {
                    bounds.min.y
                } else {
                    bounds.max.y
                },
                if i & 4 == 0 {
                    bounds.min.z
                } else {
                    bounds.max.z
                },
            );
            let t = view.to_view(corner);
            assert!(
                t.z > bounds.suggested_near_m(&cam),
                "corner {corner} behind the near plane"
            );
            let [u, v] = view.to_pixel(t);
            assert!(
                (0.0..320.0).contains(&u) && (0.0..180.0).contains(&v),
                "{u} {v}"
            );
        }
    }
}

#[test]
fn orbit_cameras_circle_the_centre_at_constant_distance() {
    let bounds = Bounds {
        min: Vec3::splat(-0.1),
        max: Vec3::splat(0.1),
    };
    let orbit = OrbitPath::around(&bounds, Vec3::Z, 40.0, 64, 64);
    let cams = orbit.cameras(12).unwrap();
    assert_eq!(cams.len(), 12);
    let elevation = orbit.elevation_deg.to_radians();
    for (i, cam) in cams.iter().enumerate() {
        let offset = cam.position - orbit.centre;
        assert!((offset.length() - orbit.distance_m).abs() < 1e-5);
        assert!((offset.z - orbit.distance_m * elevation.sin()).abs() < 1e-5);
        let azimuth = offset.y.atan2(offset.x);
        let expected = std::f32::consts::TAU * i as f32 / 12.0;
        let wrapped = (azimuth - expected).rem_euclid(std::f32::consts::TAU);
        assert!(
            !(1e-4..=std::f32::consts::TAU - 1e-4).contains(&wrapped),
            "camera {i}"
        );
        assert_eq!(cam.look_at, orbit.centre);
    }
}
