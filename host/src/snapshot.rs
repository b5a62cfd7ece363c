//! Pictures of the bed: PNG/SVG drawn to scale, and VTK files over time for
//! ParaView (a `.vtk.series` file lists them with their times).

use crate::beds::BedJob;
use crate::config::Config;
use crate::control::Control;
use crate::error::HostError;
use crate::output::{create_dir, write_json, write_text};
use crate::plot::{save, BedFigure, Disc};
use crate::sims::{run_steps, with_sim, SimJob, NEIGHBOURS};
use indicatif::ProgressBar;
use mbs_kernel::flow::Profile;
use mbs_kernel::{FlowConfig, GrainSpec, Real, Sim};
use serde::Serialize;
use std::fmt::Write;
use std::path::Path;
use std::sync::atomic::AtomicBool;

/// The grains at one instant.
#[derive(Debug, Clone, PartialEq)]
pub struct Frame {
    /// Time (s).
    pub time: f64,
    /// Periodic width (m).
    pub width: f64,
    /// Every grain.
    pub grains: Vec<GrainSpec>,
    /// The flow, if on.
    pub flow: Option<FlowConfig>,
    /// The mean bed level (m) the flow last used (docs/model.md §6), once
    /// the flow has stepped.
    pub bed_level: Option<f64>,
}

/// What a snapshot run is asked to do.
pub struct Snapshots<'a> {
    /// Configuration.
    pub config: &'a Config,
    /// Shields number of the flow.
    pub tau_star: f64,
    /// Seed.
    pub seed: u64,
    /// Frames after the settled one.
    pub frames: u64,
    /// Integration steps between frames.
    pub every: u64,
    /// Progress (in steps).
    pub progress: &'a ProgressBar,
}

impl SimJob for Snapshots<'_> {
    type Output = Result<Vec<Frame>, HostError>;

    fn run<R: Real, const N: usize>(self, sim: &mut Sim<R, N, NEIGHBOURS>) -> Self::Output {
        let config = self.config;
        let setup = config.setup(self.tau_star, self.seed);
        let fail = || {
            HostError::kernel(format!(
                "snapshot tau* = {}, seed {}",
                self.tau_star, self.seed
            ))
        };
        // Settled as a cell's bed is ([`crate::beds`]), not kept.
        let never = AtomicBool::new(false);
        let bed = BedJob {
            config,
            seed: self.seed,
            key: 0,
            resume: None,
            control: &Control::never(&never),
            progress: self.progress,
        };
        bed.run(sim)?;
        sim.set_flow(Some(&setup.flow)).map_err(fail())?;
        let frame = |sim: &Sim<R, N, NEIGHBOURS>, flowed: bool| Frame {
            time: sim.time(),
            width: sim.config().width,
            grains: (0..sim.len()).filter_map(|i| sim.grain(i)).collect(),
            flow: sim.flow().copied(),
            bed_level: flowed.then(|| sim.bed_level()),
        };
        let mut out = vec![frame(sim, false)];
        for _ in 0..self.frames {
            run_steps(sim, self.every, self.progress).map_err(fail())?;
            out.push(frame(sim, self.every > 0));
        }
        Ok(out)
    }
}

/// Runs the snapshot job.
pub fn snapshots(job: Snapshots<'_>) -> Result<Vec<Frame>, HostError> {
    let (precision, capacity) = (job.config.precision, job.config.capacity);
    with_sim(precision, capacity, job)
}

/// A frame as legacy-VTK polydata: one vertex per grain with diameter,
/// velocity, speed, spin, fixed flag and size class.
pub fn vtk(frame: &Frame) -> String {
    let g = &frame.grains;
    let n = g.len();
    let mut s = String::new();
    // Writing to a String cannot fail.
    let _ = writeln!(
        s,
        "# vtk DataFile Version 3.0\nmbs bed at t = {} s\nASCII\nDATASET POLYDATA\nPOINTS {n} double",
        frame.time
    );
    for p in g {
        let _ = writeln!(s, "{} {} 0", p.x, p.y);
    }
    let _ = writeln!(s, "VERTICES {n} {}", 2 * n);
    for i in 0..n {
        let _ = writeln!(s, "1 {i}");
    }
    let _ = writeln!(s, "POINT_DATA {n}");
    let scalar = |s: &mut String, name: &str, kind: &str, f: &dyn Fn(&GrainSpec) -> String| {
        let _ = writeln!(s, "SCALARS {name} {kind} 1\nLOOKUP_TABLE default");
        for p in g {
            let _ = writeln!(s, "{}", f(p));
        }
    };
    scalar(&mut s, "diameter", "double", &|p| p.diameter.to_string());
    scalar(&mut s, "speed", "double", &|p| p.u.hypot(p.v).to_string());
    scalar(&mut s, "spin", "double", &|p| p.spin.to_string());
    scalar(&mut s, "fixed", "int", &|p| u8::from(p.fixed).to_string());
    scalar(&mut s, "class", "int", &|p| p.class.to_string());
    let _ = writeln!(s, "VECTORS velocity double");
    for p in g {
        let _ = writeln!(s, "{} {} 0", p.u, p.v);
    }
    s
}

#[derive(Serialize)]
struct SeriesEntry {
    name: String,
    time: f64,
}

#[derive(Serialize)]
struct Series {
    #[serde(rename = "file-series-version")]
    version: &'static str,
    files: Vec<SeriesEntry>,
}

/// The mean flow velocity U (14) from the zero level of the log law up to
/// the highest grain: (y (m), U (m/s)); empty before the flow has stepped.
fn flow_profile(frame: &Frame) -> Vec<(f64, f64)> {
    const POINTS: u32 = 300;
    let (Some(flow), Some(bed)) = (frame.flow, frame.bed_level) else {
        return Vec::new();
    };
    let profile = Profile::<f64>::new(&flow);
    let top = frame
        .grains
        .iter()
        .map(|g| g.y + g.diameter)
        .fold(bed, f64::max);
    // Where (14) starts: 30.1 (y + 0.25 d)/k_s = 1.
    let zero = flow.roughness / 30.1 - 0.25 * flow.reference_diameter;
    // Denser near the bed, where U changes fastest.
    (0..=POINTS)
        .map(|k| {
            let f = f64::from(k) / f64::from(POINTS);
            let y = zero + (top - bed - zero) * f * f;
            (bed + y, profile.mean_velocity(y))
        })
        .collect()
}

/// Writes `dir/snapshot/bed_NNNN.vtk` for every frame, the ParaView series
/// file `dir/snapshot/bed.vtk.series`, and the last frame as
/// `dir/snapshot.png`/`.svg`.
pub fn write_snapshots(dir: &Path, frames: &[Frame], title: &str) -> Result<(), HostError> {
    let vtk_dir = dir.join("snapshot");
    create_dir(&vtk_dir)?;
    let mut files = Vec::new();
    for (k, f) in frames.iter().enumerate() {
        let name = format!("bed_{k:04}.vtk");
        write_text(&vtk_dir.join(&name), &vtk(f))?;
        files.push(SeriesEntry { name, time: f.time });
    }
    write_json(
        &vtk_dir.join("bed.vtk.series"),
        &Series {
            version: "1.0",
            files,
        },
    )?;
    if let Some(last) = frames.last() {
        let discs: Vec<Disc> = last
            .grains
            .iter()
            .map(|p| Disc {
                x: p.x,
                y: p.y,
                diameter: p.diameter,
                speed: p.u.hypot(p.v),
                fixed: p.fixed,
            })
            .collect();
        let figure = BedFigure {
            discs: &discs,
            width: last.width,
            title: format!("{title}, t = {:.3} s", last.time),
            bed_level: last.bed_level,
            flow_profile: flow_profile(last),
        };
        save(&figure, dir, "snapshot")?;
    }
    Ok(())
}
