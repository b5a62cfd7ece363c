//! Pictures of the bed: PNG/SVG drawn to scale, and particle frames over
//! time for ParaView and Python ([`crate::sim::frames`]).

use crate::config::Config;
use crate::error::HostError;
use crate::figures::{save, BedFigure, Disc};
use crate::sim::control::Control;
use crate::sim::frames::{self, FrameWriter};
use crate::sim::sims::{with_sim, HostSim, SimJob};
use crate::work::beds::BedJob;
use indicatif::ProgressBar;
use mbs_kernel::flow::LogLaw;
use mbs_kernel::{FlowConfig, GrainSpec, Real};
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
    /// Where the frames go: `DIR/bed_NNNN.vtu` and `DIR/bed.pvd`.
    pub dir: &'a Path,
    /// Progress (in steps).
    pub progress: &'a ProgressBar,
}

/// What a snapshot run did: the frames written and the last one.
pub struct Snapshot {
    /// Frames written.
    pub frames: usize,
    /// The last frame.
    pub last: Frame,
}

impl SimJob for Snapshots<'_> {
    type Output = Result<Snapshot, HostError>;

    fn run<R: Real, const N: usize>(self, sim: &mut HostSim<R, N>) -> Self::Output {
        let config = self.config;
        let setup = config.setup(self.tau_star, self.seed);
        let fail = || {
            HostError::kernel(format!(
                "snapshot tau* = {}, seed {}",
                self.tau_star, self.seed
            ))
        };
        // Settled as a cell's bed is ([`crate::work::beds`]), not kept.
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
        let frame = |sim: &HostSim<R, N>, flowed: bool| Frame {
            time: sim.time(),
            width: sim.config().width,
            grains: (0..sim.len()).filter_map(|i| sim.grain(i)).collect(),
            flow: sim.flow().copied(),
            bed_level: flowed.then(|| sim.bed_level()),
        };
        let mut writer = FrameWriter::new(self.dir, "bed")?;
        writer.write(sim, sim.time())?;
        for _ in 0..self.frames {
            frames::run_tracking_frames(sim, self.every, self.progress, &mut writer)
                .map_err(fail())?;
            writer.write(sim, sim.time())?;
        }
        Ok(Snapshot {
            frames: writer.len(),
            last: frame(sim, self.every > 0 && self.frames > 0),
        })
    }
}

/// Runs the snapshot job.
pub fn snapshots(job: Snapshots<'_>) -> Result<Snapshot, HostError> {
    let (precision, capacity) = (job.config.precision, job.config.capacity);
    with_sim(precision, capacity, job)
}

/// The mean flow velocity U (14) from the zero level of the log law up to
/// the highest grain: (y (m), U (m/s)); empty before the flow has stepped.
fn flow_profile(frame: &Frame) -> Vec<(f64, f64)> {
    const POINTS: u32 = 300;
    let (Some(flow), Some(bed)) = (frame.flow, frame.bed_level) else {
        return Vec::new();
    };
    let log_law = LogLaw::<f64>::new(&flow);
    let top = frame
        .grains
        .iter()
        .map(|g| g.y + g.diameter)
        .fold(bed, f64::max);
    // Where (14) starts: 30.1 (y + 0.25 d)/k_sr = 1.
    let zero = flow.spec.zero_velocity_height();
    // Denser near the bed, where U changes fastest.
    (0..=POINTS)
        .map(|k| {
            let f = f64::from(k) / f64::from(POINTS);
            let y = zero + (top - bed - zero) * f * f;
            (bed + y, log_law.mean_velocity(y))
        })
        .collect()
}

/// Draws `frame` as `dir/snapshot.png`/`.svg`.
pub fn write_picture(dir: &Path, frame: &Frame, title: &str) -> Result<(), HostError> {
    let discs: Vec<Disc> = frame
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
        width: frame.width,
        title: format!("{title}, t = {:.3} s", frame.time),
        bed_level: frame.bed_level,
        flow_profile: flow_profile(frame),
    };
    save(&figure, dir, "snapshot")
}
