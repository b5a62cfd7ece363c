//! Particle frames (issue 28): `mbs snapshot` writes XML VTK files
//! (`bed_NNNN.vtu`) and their collection (`bed.pvd`) with each grain's id,
//! radius, velocity, spin, fixed flag, size class and unwrapped x, and the
//! time. The arrays are read here as ParaView and meshio read them: the
//! base64 block after its UInt64 length, little-endian.

use crate::common::*;
use base64::Engine;
use std::collections::HashMap;
use std::path::Path;

/// One frame's arrays by name (the points as `points`), as f64, and its
/// field data.
struct Frame {
    points: usize,
    arrays: HashMap<String, Vec<f64>>,
    fields: HashMap<String, f64>,
}

/// Decodes one binary `<DataArray>` of 8-byte floats or integers, or bytes.
fn decode(node: roxmltree::Node) -> Vec<f64> {
    assert_eq!(node.attribute("format"), Some("binary"));
    let bytes = base64::engine::general_purpose::STANDARD
        .decode(node.text().unwrap_or(""))
        .unwrap();
    let (len, data) = bytes.split_at(8);
    let len = u64::from_le_bytes(len.try_into().unwrap()) as usize;
    assert_eq!(len, data.len(), "the header gives the data's length");
    match node.attribute("type").unwrap() {
        "Float64" => data
            .chunks(8)
            .map(|c| f64::from_le_bytes(c.try_into().unwrap()))
            .collect(),
        "Int64" => data
            .chunks(8)
            .map(|c| i64::from_le_bytes(c.try_into().unwrap()) as f64)
            .collect(),
        "UInt8" => data.iter().map(|&b| f64::from(b)).collect(),
        other => panic!("type {other}"),
    }
}

fn read_frame(path: &Path) -> Frame {
    let text = std::fs::read_to_string(path).unwrap();
    let doc = roxmltree::Document::parse(&text).unwrap();
    let root = doc.root_element();
    assert_eq!(root.attribute("type"), Some("UnstructuredGrid"));
    assert_eq!(root.attribute("header_type"), Some("UInt64"));
    assert_eq!(root.attribute("byte_order"), Some("LittleEndian"));
    let piece = doc.descendants().find(|n| n.has_tag_name("Piece")).unwrap();
    let points: usize = piece.attribute("NumberOfPoints").unwrap().parse().unwrap();
    assert_eq!(
        piece.attribute("NumberOfCells"),
        Some(points.to_string().as_str())
    );
    let (mut arrays, mut fields) = (HashMap::new(), HashMap::new());
    for node in doc.descendants().filter(|n| n.has_tag_name("DataArray")) {
        let parent = node.parent_element().unwrap().tag_name().name();
        let values = decode(node);
        let components: usize = node
            .attribute("NumberOfComponents")
            .map_or(1, |c| c.parse().unwrap());
        match parent {
            "FieldData" => {
                assert_eq!(values.len(), 1);
                fields.insert(node.attribute("Name").unwrap().to_string(), values[0]);
            }
            "Points" => {
                assert_eq!((components, values.len()), (3, 3 * points));
                arrays.insert("points".to_string(), values);
            }
            _ => {
                assert_eq!(values.len(), components * points);
                arrays.insert(node.attribute("Name").unwrap().to_string(), values);
            }
        }
    }
    Frame {
        points,
        arrays,
        fields,
    }
}

/// `bed.pvd`'s frames: file name and time.
fn read_collection(dir: &Path) -> Vec<(String, f64)> {
    let text = std::fs::read_to_string(dir.join("bed.pvd")).unwrap();
    let doc = roxmltree::Document::parse(&text).unwrap();
    assert_eq!(doc.root_element().attribute("type"), Some("Collection"));
    doc.descendants()
        .filter(|n| n.has_tag_name("DataSet"))
        .map(|n| {
            let time = n.attribute("timestep").unwrap().parse().unwrap();
            (n.attribute("file").unwrap().to_string(), time)
        })
        .collect()
}

/// `mbs snapshot` of the small bed at τ* = 0.3: `frames` frames after the
/// settled one, `every` seconds apart; the frames in order.
fn snapshot(dir: &Path, frames: u32, every: f64) -> Vec<(f64, Frame)> {
    let cfg = write(dir, "small.toml", SMALL);
    mbs()
        .arg("snapshot")
        .arg(&cfg)
        .args(["--tau", "0.3", "--frames", &frames.to_string()])
        .args(["--every", &every.to_string(), "--out"])
        .arg(dir)
        .assert()
        .success();
    let snapshot = dir.join("snapshot");
    let list = read_collection(&snapshot);
    assert_eq!(
        list.len(),
        frames as usize + 1,
        "the collection lists every frame"
    );
    list.iter()
        .enumerate()
        .map(|(k, (file, time))| {
            assert_eq!(file, &format!("bed_{k:04}.vtu"));
            let frame = read_frame(&snapshot.join(file));
            assert_eq!(frame.fields["TimeValue"], *time, "{file}: the time");
            (*time, frame)
        })
        .collect()
}

#[test]
fn frames_carry_every_grain_with_its_arrays_and_time() {
    let dir = tempfile::tempdir().unwrap();
    let frames = snapshot(dir.path(), 3, 0.005);
    // The settled bed when the flow starts, then every 0.005 s.
    let times: Vec<f64> = frames.iter().map(|(t, _)| *t).collect();
    for (k, t) in times.iter().enumerate() {
        assert!((t - (0.05 + 0.005 * k as f64)).abs() < 1e-9, "{times:?}");
    }
    // 5 columns: 5 fixed grains and 5 × 4 mobile ones of d = 0.5 mm.
    let n = 25;
    for (t, f) in &frames {
        let a = &f.arrays;
        assert_eq!(f.points, n, "t = {t}");
        let ids: Vec<f64> = (0..n).map(|i| i as f64).collect();
        assert_eq!(a["id"], ids);
        assert_eq!(a["connectivity"], ids);
        assert!(a["types"].iter().all(|&t| t == 1.0), "vertex cells");
        assert!(a["radius"].iter().all(|&r| r == 0.25e-3));
        assert_eq!(a["fixed"].iter().filter(|&&x| x == 1.0).count(), 5);
        assert!(a["fixed"].iter().all(|&x| x == 0.0 || x == 1.0));
        assert!(a["class"].iter().all(|&c| c == 0.0));
        assert!(a["spin"].iter().all(|s| s.is_finite()));
        // z = 0 for the points and the velocities.
        assert!(a["points"].chunks(3).all(|p| p[2] == 0.0));
        assert!(a["velocity"].chunks(3).all(|v| v[2] == 0.0));
        let width = f.fields["width"];
        assert!((width - 5.0 * 1.05 * 0.5e-3).abs() < 1e-12);
        // Fixed grains never move.
        for i in (0..n).filter(|&i| a["fixed"][i] == 1.0) {
            assert_eq!(a["velocity"][3 * i], 0.0);
        }
    }
    // The flow moves the mobile grains.
    let last = &frames[frames.len() - 1].1.arrays;
    assert!(last["velocity"].chunks(3).any(|v| v[0] > 1e-3));
}

/// The unwrapped x differs from x by whole periodic widths and follows
/// each grain across the seam between frames: two frames 0.2 s apart, in
/// which grains move 0.6 to 1 width (where the nearest image would be the
/// wrong one), give the same unwrapped x as frames 1 ms apart, and those
/// agree with x unwrapped here frame by frame.
#[test]
fn unwrapped_x_follows_the_grains_across_the_seam() {
    let (coarse_dir, dense_dir) = (tempfile::tempdir().unwrap(), tempfile::tempdir().unwrap());
    let coarse = snapshot(coarse_dir.path(), 1, 0.2);
    let dense = snapshot(dense_dir.path(), 200, 0.001);
    let x = |f: &Frame| -> Vec<f64> { f.arrays["points"].chunks(3).map(|p| p[0]).collect() };
    let width = dense[0].1.fields["width"];
    // Unwrapped here from frames 1 ms apart (grains move < 0.1 mm in 1 ms).
    let mut here = x(&dense[0].1);
    let mut previous = here.clone();
    let mut crossed = 0;
    for (t, f) in &dense {
        let (now, unwrapped) = (x(f), &f.arrays["x_unwrapped"]);
        for i in 0..f.points {
            let moved = now[i] - previous[i];
            here[i] += moved - width * (moved / width).round();
            let images = (unwrapped[i] - now[i]) / width;
            let k = images.round();
            assert!((images - k).abs() < 1e-9, "t = {t}: x_unwrapped - x = k L");
            assert_eq!(
                k,
                ((here[i] - now[i]) / width).round(),
                "t = {t}, grain {i}"
            );
        }
        previous = now;
        crossed = unwrapped.iter().zip(x(f)).filter(|(u, x)| *u != x).count();
    }
    assert!(crossed > 0, "some grain crossed the seam");
    for (t, f) in &coarse {
        let (_, same) = dense.iter().find(|(s, _)| s == t).unwrap();
        assert_eq!(
            f.arrays["x_unwrapped"], same.arrays["x_unwrapped"],
            "t = {t}"
        );
    }
    let far = coarse.windows(2).any(|w| {
        let (before, after) = (&w[0].1.arrays["x_unwrapped"], &w[1].1.arrays["x_unwrapped"]);
        before.iter().zip(after).any(|(b, a)| a - b > 0.5 * width)
    });
    assert!(
        far,
        "a grain moved more than half the width between two frames"
    );
}
