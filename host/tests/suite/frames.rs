//! Particle frames (issue 28): `mbs snapshot` writes XML VTK files
//! (`bed_NNNN.vtu`) and their collection (`bed.pvd`) with each grain's id,
//! radius, velocity, spin, fixed flag, size class, unwrapped x, contact
//! force and stress, and the
//! time. The arrays are read here as ParaView and meshio read them: the
//! base64 block after its UInt64 length, little-endian. `mbs run
//! --dump-every` writes the same frames for each cell under the flow.

use crate::common::*;
use base64::Engine;
use std::collections::HashMap;
use std::path::{Path, PathBuf};

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
    read_pvd(&dir.join("bed.pvd"))
}

/// A collection's frames: file name and time.
fn read_pvd(path: &Path) -> Vec<(String, f64)> {
    let text = std::fs::read_to_string(path).unwrap();
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
        // The contacts' forces cancel pair by pair (Newton's third law)
        // and load the bed: the mobile grains' weight rests on it.
        let force = &a["contact_force"];
        let largest = force.iter().fold(0.0f64, |m, f| m.max(f.abs()));
        for k in 0..3 {
            let sum: f64 = force.iter().skip(k).step_by(3).sum();
            assert!(sum.abs() <= 1e-9 * largest, "t = {t}: Σ f {sum}");
        }
        assert!(largest > 0.0, "t = {t}: the bed's contacts carry loads");
        for name in ["stress_xx", "stress_yy", "stress_xy"] {
            assert!(a[name].iter().all(|s| s.is_finite()), "{name}");
        }
        // Compression: the grains' vertical normal stress is negative.
        assert!(a["stress_yy"].iter().sum::<f64>() < 0.0);
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

/// The SMALL job's cells: (τ*, seed) as their frame directories name them.
const CELLS: [&str; 4] = [
    "tau0.1_seed1",
    "tau0.1_seed2",
    "tau0.3_seed1",
    "tau0.3_seed2",
];

/// Every file under `dir` (relative path, bytes), sorted.
fn files(dir: &Path) -> Vec<(PathBuf, Vec<u8>)> {
    let mut out = Vec::new();
    let mut todo = vec![dir.to_path_buf()];
    while let Some(d) = todo.pop() {
        for e in std::fs::read_dir(&d).unwrap() {
            let p = e.unwrap().path();
            if p.is_dir() {
                todo.push(p);
            } else {
                let bytes = std::fs::read(&p).unwrap();
                out.push((p.strip_prefix(dir).unwrap().to_path_buf(), bytes));
            }
        }
    }
    out.sort();
    out
}

/// `mbs run --dump-every 0.01` on the SMALL job (0.02 s spin-up, 0.05 s
/// window): each cell writes a frame at the flow's start and every 0.01 s
/// after, 8 in all, timed from the flow's start, and the same
/// `transport.csv` as a run without frames.
#[test]
fn run_dump_every_writes_each_cells_frames_and_the_same_table() {
    let dir = tempfile::tempdir().unwrap();
    let cfg = write(dir.path(), "small.toml", SMALL);
    let (plain, dumped) = (dir.path().join("plain"), dir.path().join("dumped"));
    run_into(&cfg, &plain).assert().success();
    run_into(&cfg, &dumped)
        .args(["--dump-every", "0.01"])
        .assert()
        .success();
    assert_eq!(
        std::fs::read(plain.join("transport.csv")).unwrap(),
        std::fs::read(dumped.join("transport.csv")).unwrap(),
        "frames change no result"
    );
    assert!(!plain.join("frames").exists());
    for cell in CELLS {
        let cell_dir = dumped.join("frames").join(cell);
        let list = read_pvd(&cell_dir.join("frames.pvd"));
        assert_eq!(list.len(), 8, "{cell}: {list:?}");
        for (k, (file, time)) in list.iter().enumerate() {
            assert_eq!(file, &format!("frames_{k:04}.vtu"));
            assert!((time - 0.01 * k as f64).abs() < 1e-12, "{cell}: {list:?}");
            let frame = read_frame(&cell_dir.join(file));
            assert_eq!(frame.fields["TimeValue"], *time);
            assert_eq!(frame.points, 25);
        }
        assert!(
            !cell_dir.join("frames_resume.json").exists(),
            "{cell}: the record for resuming goes when the cell ends"
        );
        // The first frame is the settled bed at rest under the new flow.
        let first = read_frame(&cell_dir.join("frames_0000.vtu"));
        assert_eq!(first.arrays["x_unwrapped"], {
            let p = &first.arrays["points"];
            p.chunks(3).map(|p| p[0]).collect::<Vec<_>>()
        });
    }
}

/// A run stopped in its cells and resumed with the same --dump-every ends
/// with the very files of an uninterrupted run (unwrapped x included);
/// resumed with another interval, a cell's collection starts afresh at
/// the resume point on the new interval's times.
#[test]
fn resumed_cells_continue_their_frames() {
    let dir = tempfile::tempdir().unwrap();
    let cfg = write(dir.path(), "small.toml", SMALL);
    let whole = dir.path().join("whole");
    run_into(&cfg, &whole)
        .args(["--dump-every", "0.01"])
        .assert()
        .success();
    // Each bed and cell stops 13 000 steps into its invocation: the beds
    // (20 000 steps) in the first, the cells (28 000) in the second, after
    // their frame at 0.03 s of 0.0325 s.
    let stop = |dir: &Path| {
        run_into(&cfg, dir)
            .args(["--dump-every", "0.01", "--stop-after-steps", "13000"])
            .assert()
            .code(130);
        resume_in(dir)
            .args(["--dump-every", "0.01", "--stop-after-steps", "13000"])
            .assert()
            .code(130);
    };
    let resumed = dir.path().join("resumed");
    stop(&resumed);
    let cell = resumed.join("frames").join("tau0.3_seed2");
    assert_eq!(read_pvd(&cell.join("frames.pvd")).len(), 4);
    assert!(cell.join("frames_resume.json").exists());
    resume_in(&resumed)
        .args(["--dump-every", "0.01"])
        .assert()
        .success();
    assert_eq!(files(&whole.join("frames")), files(&resumed.join("frames")));
    assert_eq!(
        std::fs::read(whole.join("transport.csv")).unwrap(),
        std::fs::read(resumed.join("transport.csv")).unwrap()
    );

    let other = dir.path().join("other");
    stop(&other);
    resume_in(&other)
        .args(["--dump-every", "0.015"])
        .assert()
        .success();
    for cell in CELLS {
        let list = read_pvd(&other.join("frames").join(cell).join("frames.pvd"));
        let times: Vec<f64> = list.iter().map(|(_, t)| *t).collect();
        // 0.0325 s at the stop: 0.045 and 0.06 s.
        assert_eq!(times.len(), 2, "{cell}: {times:?}");
        for (t, want) in times.iter().zip([0.045, 0.06]) {
            assert!((t - want).abs() < 1e-12, "{cell}: {times:?}");
        }
    }
}

/// --dump-every outside (one integration step, time.window) is refused
/// before anything is written, exit 2, naming the option, the value and
/// the range.
#[test]
fn an_invalid_dump_every_is_refused() {
    let dir = tempfile::tempdir().unwrap();
    let cfg = write(dir.path(), "small.toml", SMALL);
    for bad in ["0", "-0.01", "1e-7", "0.06", "NaN", "inf"] {
        let out = dir.path().join("out");
        let assert = run_into(&cfg, &out)
            .args(["--dump-every", bad])
            .assert()
            .code(2);
        let stderr = String::from_utf8_lossy(&assert.get_output().stderr).to_string();
        assert!(stderr.contains("--dump-every"), "{bad}: {stderr}");
        assert!(
            stderr.contains("step_dt = constants_dt/substeps = 0.0000025 s")
                && stderr.contains("time.window (0.05 s)"),
            "{bad}: {stderr}"
        );
        assert!(!out.exists(), "{bad}: nothing written");
    }
}
