//! Particle frames for ParaView and Python (meshio): one XML VTK file per
//! frame, `STEM_NNNN.vtu`, and the collection `STEM.pvd` that lists the
//! frames with their times.
//!
//! Each grain is a point (z = 0) and a vertex cell with the point data
//! `id` (its index in the simulation, stable over a run), `radius` (m),
//! `velocity` (m/s, z = 0), `spin` (rad/s, counter-clockwise positive),
//! `fixed` (0 or 1), `class` (size class), `x_unwrapped` (m), and what its
//! contacts do to it ([`GrainLoad`]): `contact_force` (N, z = 0) and its
//! stress `stress_xx`, `stress_yy`, `stress_xy` (Pa); the field
//! data `TimeValue` (s) and `width` (the periodic width L, m). Arrays are
//! little-endian binary, base64 inline, exactly the simulation's numbers.
//!
//! The format is XML UnstructuredGrid, not PolyData (`.vtp`): ParaView
//! reads both, but meshio reads XML VTK only as UnstructuredGrid. The writer
//! is this module rather than the `vtkio` crate, whose XML writer drops the
//! field data (the time) and writes no `.pvd`.
//!
//! The kernel wraps x into [0, L) and keeps no image counts, so the writer
//! counts each grain's crossings of the periodic seam itself from the x it
//! sees at every [`FrameWriter::track`]: `x_unwrapped = x + images L`, with
//! the images counted from the writer's first look. That is right while no
//! grain moves half the width between two looks; [`run_tracking_frames`] and
//! [`Dumps`] look every [`TRACK_SECONDS`] of simulated time.
//!
//! [`Dumps`] writes the frames of a cell of `mbs run --dump-every`: every
//! so many integration steps since the flow started, the frame time being
//! the time since then. It keeps beside its frames, at each of the cell's
//! checkpoints, what it needs to continue them ([`RESUME`]: the frames
//! written and the image counts), so a resumed cell continues its
//! collection; without a record that fits the checkpoint it starts the
//! collection afresh. Frames are an output: nothing is computed from them.

use crate::error::HostError;
use crate::io::input::{read_own_bounded, Bound};
use crate::io::output::{create_dir, remove_if_present, write_json, write_text};
use crate::sim::threads::Stepping;
use base64::Engine;
use indicatif::ProgressBar;
use mbs_kernel::{GrainSpec, Real, Sim};
use serde::{Deserialize, Serialize};
use std::fmt::Write;
use std::path::{Path, PathBuf};

/// Simulated time (s) between two looks at the grains in [`run_tracking_frames`]: a
/// grain is unwrapped wrongly only if it moves half the periodic width in
/// this time, at L/(2 × 0.25 ms): 42 m/s on the default 21 mm bed, 3 m/s
/// on the narrowest allowed (3 columns of 0.5 mm).
pub const TRACK_SECONDS: f64 = 2.5e-4;

/// Writes particle frames (`DIR/STEM_NNNN.vtu`) and keeps their collection
/// (`DIR/STEM.pvd`) up to date after each, so an interrupted run leaves a
/// complete collection of the frames written so far.
#[derive(Debug)]
pub struct FrameWriter {
    dir: PathBuf,
    stem: String,
    /// The frames written: file name and time (s).
    entries: Vec<(String, f64)>,
    images: Images,
}

/// Each grain's x at the last look and its count of periodic images.
#[derive(Debug, Default)]
struct Images {
    width: f64,
    x: Vec<f64>,
    count: Vec<i64>,
}

impl Images {
    /// Takes the grains' new x (in [0, L)): a grain that moved more than
    /// L/2 one way is taken to have crossed the seam the other way. A
    /// different number of grains or width starts the counts afresh.
    fn track(&mut self, width: f64, x: &[f64]) {
        if x.len() != self.x.len() || width != self.width {
            *self = Images {
                width,
                x: x.to_vec(),
                count: vec![0; x.len()],
            };
            return;
        }
        for ((old, count), &new) in self.x.iter_mut().zip(&mut self.count).zip(x) {
            let moved = new - *old;
            if moved < -0.5 * width {
                *count += 1;
            } else if moved > 0.5 * width {
                *count -= 1;
            }
            *old = new;
        }
    }

    /// x + images L of every grain.
    fn unwrapped(&self) -> Vec<f64> {
        let images = self.count.iter().map(|&k| k as f64 * self.width);
        self.x.iter().zip(images).map(|(x, d)| x + d).collect()
    }
}

impl FrameWriter {
    /// A writer of `dir/stem_NNNN.vtu` and `dir/stem.pvd`; creates `dir`.
    pub fn new(dir: &Path, stem: &str) -> Result<Self, HostError> {
        crate::io::output::refuse_link(dir)?;
        create_dir(dir)?;
        Ok(FrameWriter {
            dir: dir.to_path_buf(),
            stem: stem.to_string(),
            entries: Vec::new(),
            images: Images::default(),
        })
    }

    /// Looks at the grains' x to count their crossings of the periodic seam;
    /// call it at least every [`TRACK_SECONDS`] between frames (as
    /// [`run_tracking_frames`] does).
    pub fn track<R: Real, const N: usize, const K: usize, const C: usize>(
        &mut self,
        sim: &Sim<R, N, K, C>,
    ) {
        let x: Vec<f64> = (0..sim.len())
            .filter_map(|i| sim.grain(i))
            .map(|g| g.x)
            .collect();
        self.images.track(sim.config().width, &x);
    }

    /// Writes the next frame of `sim` at `time` (s), and the `.pvd` listing
    /// every frame so far. Returns the frame's path.
    pub fn write<R: Real, const N: usize, const K: usize, const C: usize>(
        &mut self,
        sim: &Sim<R, N, K, C>,
        time: f64,
    ) -> Result<PathBuf, HostError> {
        self.track(sim);
        let grains: Vec<GrainSpec> = (0..sim.len()).filter_map(|i| sim.grain(i)).collect();
        let name = self.name(self.entries.len());
        let path = self.dir.join(&name);
        let unwrapped = self.images.unwrapped();
        let loads = grain_loads(sim, &grains);
        write_text(
            &path,
            &vtu(&grains, &loads, &unwrapped, self.images.width, time),
        )?;
        self.entries.push((name, time));
        write_text(&self.pvd_path(), &pvd(&self.entries))?;
        Ok(path)
    }

    /// The file name of frame `k`, `stem_NNNN.vtu`.
    fn name(&self, k: usize) -> String {
        format!("{}_{k:04}.vtu", self.stem)
    }

    /// The collection file, `dir/stem.pvd`.
    pub fn pvd_path(&self) -> PathBuf {
        self.dir.join(format!("{}.pvd", self.stem))
    }

    /// Frames written so far.
    pub fn len(&self) -> usize {
        self.entries.len()
    }

    /// No frame written yet.
    pub fn is_empty(&self) -> bool {
        self.entries.is_empty()
    }
}

/// Runs `steps` steps like [`crate::sim::sims::run_with_progress`], letting `frames`
/// [`FrameWriter::track`] the grains every [`TRACK_SECONDS`].
pub fn run_tracking_frames<R: Real, const N: usize, const K: usize, const C: usize>(
    sim: &mut Sim<R, N, K, C>,
    steps: u64,
    progress: &ProgressBar,
    frames: &mut FrameWriter,
) -> Result<(), mbs_kernel::Error> {
    // At least one step per look; a float-to-int cast saturates.
    let every = ((TRACK_SECONDS / sim.config().step_dt) as u64).max(1);
    let mut left = steps;
    while left > 0 {
        let n = left.min(every);
        sim.run(n)?;
        frames.track(sim);
        progress.inc(n);
        left -= n;
    }
    Ok(())
}

/// The file beside a cell's frames that records, at the cell's last
/// checkpoint, what its frames need to continue ([`Dumps::resume`]);
/// removed when the cell ends.
pub const RESUME: &str = "frames_resume.json";

/// The record in [`RESUME`]: all integers, so it reads back exactly.
#[derive(Debug, PartialEq, Serialize, Deserialize)]
struct Record {
    /// Steps between frames.
    every: u64,
    /// Steps since the flow started, at the checkpoint.
    step: u64,
    /// The periodic width's bits.
    width: u64,
    /// The frames written: steps since the flow started, in order.
    frames: Vec<u64>,
    /// Each grain's periodic images.
    images: Vec<i64>,
}

/// The frames of a cell under the flow (`mbs run --dump-every`): one every
/// `every` integration steps since the flow started (step `origin` of the
/// simulation), at the time since then, into `dir/frames_NNNN.vtu` and
/// `dir/frames.pvd`.
#[derive(Debug)]
pub struct Dumps {
    writer: FrameWriter,
    /// Steps between frames (at least 1).
    every: u64,
    /// Steps between looks at the grains (at least 1).
    track: u64,
    /// The simulation's step count when the flow started.
    origin: u64,
    step_dt: f64,
    /// Each frame's steps since the flow started.
    steps: Vec<u64>,
}

impl Dumps {
    /// Starts the frames of a cell in `dir` afresh (earlier files of the
    /// directory are removed): the first frame now if the flow starts now.
    pub fn start<R: Real, const N: usize, const K: usize, const C: usize>(
        dir: &Path,
        every: u64,
        origin: u64,
        sim: &Sim<R, N, K, C>,
    ) -> Result<Self, HostError> {
        match std::fs::remove_dir_all(dir) {
            Err(e) if e.kind() != std::io::ErrorKind::NotFound => {
                return Err(HostError::io(dir)(e))
            }
            _ => {}
        }
        let step_dt = sim.config().step_dt;
        let mut dumps = Dumps {
            writer: FrameWriter::new(dir, "frames")?,
            every: every.max(1),
            // At least one step per look; a float-to-int cast saturates.
            track: ((TRACK_SECONDS / step_dt) as u64).max(1),
            origin,
            step_dt,
            steps: Vec::new(),
        };
        dumps.writer.track(sim);
        if dumps.since(sim) == 0 {
            dumps.write(sim)?;
        }
        Ok(dumps)
    }

    /// Continues the frames in `dir` of a cell restored from its checkpoint
    /// (`sim`): with the [`RESUME`] record of that very checkpoint (same
    /// step, interval, width and grains) the frames written up to it are
    /// kept, later ones removed, and the image counts taken over; else the
    /// collection starts afresh ([`Dumps::start`]).
    pub fn resume<R: Real, const N: usize, const K: usize, const C: usize>(
        dir: &Path,
        every: u64,
        origin: u64,
        sim: &Sim<R, N, K, C>,
    ) -> Result<Self, HostError> {
        let mut dumps = Self::start_keeping(dir, every, origin, sim)?;
        let path = dir.join(RESUME);
        // A frame step, and a width and image count per grain, in at most
        // 24 bytes each.
        let frames = dumps.since(sim) / dumps.every + 2;
        let bound = Bound {
            bytes: 1024 + 24 * (frames + 2 * sim.len() as u64),
            reason: "the record of a cell's frames at its checkpoint",
        };
        let record = read_own_bounded(&path, bound)
            .ok()
            .and_then(|bytes| serde_json::from_slice::<Record>(&bytes).ok())
            .filter(|r| {
                r.every == dumps.every
                    && r.step == dumps.since(sim)
                    && r.width == sim.config().width.to_bits()
                    && r.images.len() == sim.len()
                    && r.frames.windows(2).all(|w| w[0] < w[1])
                    && r.frames.last().is_none_or(|&s| s <= r.step)
            });
        let Some(record) = record else {
            return Self::start(dir, every, origin, sim);
        };
        // Frames written after the checkpoint by the interrupted run.
        let mut k = record.frames.len();
        while dir.join(dumps.writer.name(k)).exists() {
            remove_if_present(&dir.join(dumps.writer.name(k)))?;
            k += 1;
        }
        dumps.writer.images.count = record.images;
        dumps.writer.entries = record
            .frames
            .iter()
            .enumerate()
            .map(|(k, &s)| (dumps.writer.name(k), frame_time(s, dumps.step_dt)))
            .collect();
        dumps.steps = record.frames;
        write_text(&dumps.writer.pvd_path(), &pvd(&dumps.writer.entries))?;
        Ok(dumps)
    }

    /// A writer in `dir` without removing anything, looking at `sim`.
    fn start_keeping<R: Real, const N: usize, const K: usize, const C: usize>(
        dir: &Path,
        every: u64,
        origin: u64,
        sim: &Sim<R, N, K, C>,
    ) -> Result<Self, HostError> {
        let step_dt = sim.config().step_dt;
        let mut writer = FrameWriter::new(dir, "frames")?;
        writer.track(sim);
        Ok(Dumps {
            writer,
            every: every.max(1),
            track: ((TRACK_SECONDS / step_dt) as u64).max(1),
            origin,
            step_dt,
            steps: Vec::new(),
        })
    }

    /// Steps since the flow started.
    fn since<R: Real, const N: usize, const K: usize, const C: usize>(
        &self,
        sim: &Sim<R, N, K, C>,
    ) -> u64 {
        sim.step_count().saturating_sub(self.origin)
    }

    /// Writes the frame of now.
    fn write<R: Real, const N: usize, const K: usize, const C: usize>(
        &mut self,
        sim: &Sim<R, N, K, C>,
    ) -> Result<(), HostError> {
        let step = self.since(sim);
        self.writer.write(sim, frame_time(step, self.step_dt))?;
        self.steps.push(step);
        Ok(())
    }

    /// Runs `steps` steps in pieces that end on every frame (written) and
    /// at least every [`TRACK_SECONDS`] (a look): the same bits as one
    /// `sim.run(steps)`, each piece run by `stepping`. A kernel error goes
    /// through `fail`.
    pub fn run<R: Real, const N: usize, const K: usize, const C: usize>(
        &mut self,
        sim: &mut Sim<R, N, K, C>,
        stepping: &mut Stepping<R, N, K>,
        steps: u64,
        fail: impl Fn(mbs_kernel::Error) -> HostError,
    ) -> Result<(), HostError> {
        let mut left = steps;
        while left > 0 {
            let to_frame = self.every - self.since(sim) % self.every;
            let n = left.min(self.track).min(to_frame);
            stepping.run(sim, n).map_err(&fail)?;
            left -= n;
            if n == to_frame {
                self.write(sim)?;
            } else {
                self.writer.track(sim);
            }
        }
        Ok(())
    }

    /// Writes the [`RESUME`] record of now: call it with each checkpoint of
    /// the cell, before the checkpoint is written.
    pub fn save<R: Real, const N: usize, const K: usize, const C: usize>(
        &mut self,
        sim: &Sim<R, N, K, C>,
    ) -> Result<(), HostError> {
        self.writer.track(sim);
        let record = Record {
            every: self.every,
            step: self.since(sim),
            width: sim.config().width.to_bits(),
            frames: self.steps.clone(),
            images: self.writer.images.count.clone(),
        };
        write_json(&self.writer.dir.join(RESUME), &record)
    }

    /// The cell has ended: its [`RESUME`] record is removed.
    pub fn finish(self) -> Result<(), HostError> {
        remove_if_present(&self.writer.dir.join(RESUME))
    }

    /// Frames written so far.
    pub fn len(&self) -> usize {
        self.writer.len()
    }

    /// No frame written yet.
    pub fn is_empty(&self) -> bool {
        self.writer.is_empty()
    }
}

/// One `<DataArray>` of VTK type `kind` with `attributes`: the
/// little-endian `bytes`, written base64 after their length (UInt64).
fn data_array(out: &mut String, kind: &str, attributes: &str, bytes: &[u8]) {
    let mut block = (bytes.len() as u64).to_le_bytes().to_vec();
    block.extend_from_slice(bytes);
    // Writing to a String cannot fail.
    let _ = writeln!(
        out,
        "<DataArray type=\"{kind}\" {attributes} format=\"binary\">{}</DataArray>",
        base64::engine::general_purpose::STANDARD.encode(block)
    );
}

/// A named array of `components` per point or cell (scalars say none, so
/// that meshio reads them as flat arrays).
fn named(out: &mut String, kind: &str, name: &str, components: usize, bytes: &[u8]) {
    let mut attributes = format!("Name=\"{name}\"");
    if components > 1 {
        let _ = write!(attributes, " NumberOfComponents=\"{components}\"");
    }
    data_array(out, kind, &attributes, bytes);
}

fn float64(values: impl Iterator<Item = f64>) -> Vec<u8> {
    values.flat_map(f64::to_le_bytes).collect()
}

fn int64(values: impl Iterator<Item = i64>) -> Vec<u8> {
    values.flat_map(i64::to_le_bytes).collect()
}

/// What a grain's contacts do to it now ([`Sim::contact_forces`]): the sum
/// of their forces (N) and its stress (Pa), σ = (1/V) Σ f ⊗ r, r from its
/// centre to the contact point (the branch times r_i/(r_i + r_j)), as
/// (σ_xx, σ_yy, σ_xy), compression negative.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct GrainLoad {
    /// Σ f (N).
    pub force: [f64; 2],
    /// (σ_xx, σ_yy, σ_xy) (Pa).
    pub stress: [f64; 3],
}

/// Each grain's [`GrainLoad`] in `sim` now (`grains`: its grains).
pub fn grain_loads<R: Real, const N: usize, const K: usize, const C: usize>(
    sim: &Sim<R, N, K, C>,
    grains: &[GrainSpec],
) -> Vec<GrainLoad> {
    let mut loads = vec![GrainLoad::default(); grains.len()];
    let radius = |i: usize| grains.get(i).map_or(0.0, |g| 0.5 * g.diameter);
    sim.contact_forces(|c| {
        let (ri, rj) = (radius(c.i), radius(c.j));
        for (k, sign, share) in [(c.i, 1.0, ri), (c.j, -1.0, rj)] {
            let Some(load) = loads.get_mut(k) else {
                continue;
            };
            let f = [sign * c.force[0], sign * c.force[1]];
            // From k's centre to the contact point: ± the branch's share.
            let r = share / (ri + rj);
            let arm = [sign * c.branch[0] * r, sign * c.branch[1] * r];
            let volume = 4.0 / 3.0 * std::f64::consts::PI * share * share * share;
            load.force[0] += f[0];
            load.force[1] += f[1];
            load.stress[0] += f[0] * arm[0] / volume;
            load.stress[1] += f[1] * arm[1] / volume;
            load.stress[2] += 0.5 * (f[0] * arm[1] + f[1] * arm[0]) / volume;
        }
    });
    loads
}

/// A frame as an XML VTK UnstructuredGrid of vertex cells, one per grain
/// (see the module's documentation for the arrays); `loads` as many as
/// `grains` (missing ones are written as zero).
pub fn vtu(
    grains: &[GrainSpec],
    loads: &[GrainLoad],
    x_unwrapped: &[f64],
    width: f64,
    time: f64,
) -> String {
    let n = grains.len();
    let mut s = String::from(
        "<?xml version=\"1.0\"?>\n\
         <VTKFile type=\"UnstructuredGrid\" version=\"1.0\" byte_order=\"LittleEndian\" header_type=\"UInt64\">\n\
         <UnstructuredGrid>\n<FieldData>\n",
    );
    for (name, value) in [("TimeValue", time), ("width", width)] {
        let attributes = format!("Name=\"{name}\" NumberOfTuples=\"1\"");
        data_array(&mut s, "Float64", &attributes, &value.to_le_bytes());
    }
    let _ = writeln!(
        s,
        "</FieldData>\n<Piece NumberOfPoints=\"{n}\" NumberOfCells=\"{n}\">\n<Points>"
    );
    let points = grains.iter().flat_map(|g| [g.x, g.y, 0.0]);
    data_array(
        &mut s,
        "Float64",
        "NumberOfComponents=\"3\"",
        &float64(points),
    );
    s.push_str("</Points>\n<Cells>\n");
    named(&mut s, "Int64", "connectivity", 1, &int64(0..n as i64));
    named(&mut s, "Int64", "offsets", 1, &int64(1..=n as i64));
    // VTK_VERTEX = 1.
    named(&mut s, "UInt8", "types", 1, &vec![1u8; n]);
    s.push_str("</Cells>\n<PointData Scalars=\"radius\" Vectors=\"velocity\">\n");
    named(&mut s, "Int64", "id", 1, &int64(0..n as i64));
    let radius = grains.iter().map(|g| 0.5 * g.diameter);
    named(&mut s, "Float64", "radius", 1, &float64(radius));
    let velocity = grains.iter().flat_map(|g| [g.u, g.v, 0.0]);
    named(&mut s, "Float64", "velocity", 3, &float64(velocity));
    named(
        &mut s,
        "Float64",
        "spin",
        1,
        &float64(grains.iter().map(|g| g.spin)),
    );
    let fixed: Vec<u8> = grains.iter().map(|g| u8::from(g.fixed)).collect();
    named(&mut s, "UInt8", "fixed", 1, &fixed);
    let class: Vec<u8> = grains.iter().map(|g| g.class).collect();
    named(&mut s, "UInt8", "class", 1, &class);
    let unwrapped = float64(x_unwrapped.iter().copied());
    named(&mut s, "Float64", "x_unwrapped", 1, &unwrapped);
    let load = |i: usize| loads.get(i).copied().unwrap_or_default();
    let force = (0..n).flat_map(|i| [load(i).force[0], load(i).force[1], 0.0]);
    named(&mut s, "Float64", "contact_force", 3, &float64(force));
    for (k, name) in ["stress_xx", "stress_yy", "stress_xy"].iter().enumerate() {
        named(
            &mut s,
            "Float64",
            name,
            1,
            &float64((0..n).map(|i| load(i).stress[k])),
        );
    }
    s.push_str("</PointData>\n</Piece>\n</UnstructuredGrid>\n</VTKFile>\n");
    s
}

/// The time (s) of a frame `steps` integration steps of `step_dt` after the
/// flow started, to 12 significant digits: 0.03, not the product's
/// 0.030000000000000002.
///
/// ```
/// use mbs::sim::frames::frame_time;
///
/// assert_eq!(frame_time(12_000, 2.5e-6), 0.03);
/// assert_eq!(frame_time(0, 2.5e-6), 0.0);
/// ```
pub fn frame_time(steps: u64, step_dt: f64) -> f64 {
    let t = steps as f64 * step_dt;
    format!("{t:.11e}").parse().unwrap_or(t)
}

/// The ParaView collection of `entries` (file name, time in s).
pub fn pvd(entries: &[(String, f64)]) -> String {
    let mut s = String::from(
        "<?xml version=\"1.0\"?>\n\
         <VTKFile type=\"Collection\" version=\"1.0\" byte_order=\"LittleEndian\">\n<Collection>\n",
    );
    for (file, time) in entries {
        let _ = writeln!(
            s,
            "<DataSet timestep=\"{time}\" group=\"\" part=\"0\" file=\"{file}\"/>"
        );
    }
    s.push_str("</Collection>\n</VTKFile>\n");
    s
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn images_count_the_seam_crossings_both_ways() {
        let mut images = Images::default();
        let width = 1.0;
        // Grain 0 drifts right across the seam twice, grain 1 left once,
        // grain 2 stays.
        let frames: [[f64; 3]; 5] = [
            [0.25, 0.375, 0.5],
            [0.75, 0.125, 0.5],
            [0.125, 0.875, 0.5],
            [0.625, 0.625, 0.5],
            [0.0625, 0.5, 0.5],
        ];
        for x in &frames {
            images.track(width, x);
        }
        assert_eq!(images.count, [2, -1, 0]);
        assert_eq!(images.unwrapped(), [2.0625, -0.5, 0.5]);
    }

    #[test]
    fn images_start_afresh_for_other_grains_or_width() {
        let mut images = Images::default();
        images.track(1.0, &[0.9]);
        images.track(1.0, &[0.1]);
        assert_eq!(images.count, [1]);
        images.track(1.0, &[0.1, 0.2]);
        assert_eq!(images.count, [0, 0]);
        images.track(1.0, &[0.9, 0.2]);
        images.track(2.0, &[0.9, 0.2]);
        assert_eq!(images.count, [0, 0]);
    }

    #[test]
    fn the_collection_lists_every_frame_with_its_time() {
        let entries = [
            ("a_0000.vtu".to_string(), 0.5),
            ("a_0001.vtu".to_string(), 0.75),
        ];
        let text = pvd(&entries);
        let doc = roxmltree::Document::parse(&text).unwrap();
        let sets: Vec<(&str, f64)> = doc
            .descendants()
            .filter(|n| n.has_tag_name("DataSet"))
            .map(|n| {
                let t = n.attribute("timestep").unwrap().parse().unwrap();
                (n.attribute("file").unwrap(), t)
            })
            .collect();
        assert_eq!(sets, [("a_0000.vtu", 0.5), ("a_0001.vtu", 0.75)]);
    }

    #[test]
    fn a_frame_without_grains_is_valid_xml() {
        let text = vtu(&[], &[], &[], 1.0, 0.0);
        let doc = roxmltree::Document::parse(&text).unwrap();
        let piece = doc.descendants().find(|n| n.has_tag_name("Piece")).unwrap();
        assert_eq!(piece.attribute("NumberOfPoints"), Some("0"));
    }
}
