//! `mbs digest`: the state digests after settling and flow steps, digest
//! traces, and their checks (docs/determinism.md).

use super::common::tau_arg;
use super::common::Invocation;
use super::common::Shared;
use super::common::{print, print_err};
use crate::config::Precision;
use crate::config::{canonical, long_steps_warning, steps_arg, Config, ConfigFile};
use crate::error::ConfigError;
use crate::error::HostError;
use crate::io::input::read_text_bounded;
use crate::io::output::write_text;
use crate::io::text::shown;
use crate::sim::sims::with_sim;
use crate::sim::sims::HostSim;
use crate::sim::sims::SimJob;
use crate::tools::trace::TRACE_BOUND;
use mbs_kernel::Real;
use mbs_kernel::Scenario;
use std::path::Path;

use clap::Args;
use std::path::PathBuf;

/// The arguments of `mbs digest`.
#[derive(Args)]
pub struct DigestArgs {
    /// Shared options.
    #[command(flatten)]
    pub shared: Shared,
    /// Configuration file (TOML); without one, the golden-digest run: the
    /// paper's case on its 5 columns, as the firmware runs it.
    pub config: Option<PathBuf>,
    /// Steps of each phase (of settling only, with --flow-steps).
    #[arg(long, default_value_t = 2000)]
    pub steps: u64,
    /// Steps of the flow phase (default: --steps).
    #[arg(long)]
    pub flow_steps: Option<u64>,
    /// Working precision.
    #[arg(long, value_enum, default_value_t = Precision::F64)]
    pub precision: Precision,
    /// Shields number of the flow phase.
    #[arg(long, default_value_t = 0.2, allow_negative_numbers = true)]
    pub tau: f64,
    /// Also write a trace of the run (JSON, docs/determinism.md "Traces").
    #[arg(long, value_name = "FILE")]
    pub trace: Option<PathBuf>,
    /// Integration steps between the trace's records.
    #[arg(long, default_value_t = 1000, requires = "trace")]
    pub every: u64,
    /// The trace's first recorded step (the run starts at 0 regardless).
    #[arg(long, default_value_t = 0, requires = "trace")]
    pub from: u64,
    /// The trace's last step (default: the end of the flow phase).
    #[arg(long, requires = "trace")]
    pub until: Option<u64>,
    /// Each record of the trace keeps the whole kernel state (base64), so
    /// that a check can name the grains and fields that differ.
    #[arg(long, requires = "trace")]
    pub states: bool,
    /// Re-run a trace's scenario and compare: exit 0 if every record
    /// matches, 1 locating the first mismatch, 2 for a damaged or foreign trace.
    #[arg(long, value_name = "TRACE", conflicts_with_all = ["config", "trace"])]
    pub check: Option<PathBuf>,
    /// With --check: change one grain's field by ULPS units in the last
    /// place after STEP integration steps (ULPS 1 if omitted; fields x, y,
    /// u, v, spin, draw_u, draw_v), to see how the check locates a difference.
    #[arg(long, value_name = "STEP:GRAIN:FIELD[:ULPS]", requires = "check")]
    pub nudge: Option<crate::tools::trace::Nudge>,
}

impl DigestArgs {
    /// A check of a trace (`--check`), or a digest run, with a trace if asked.
    pub fn execute(self, how: &Invocation) -> Result<(), HostError> {
        if let Some(file) = self.check {
            how.refuse_sets(
                "absent with --check: a check runs the configuration the trace carries",
            )?;
            return check_trace(&file, self.nudge);
        }
        if self.every == 0 {
            return Err(ConfigError::Invalid {
                key: "--every".into(),
                value: self.every.to_string(),
                allowed: "> 0".into(),
            }
            .into());
        }
        let name = self.config.as_ref().map(|p| p.display().to_string());
        let config = match &self.config {
            Some(path) => how.load(Some(path))?,
            None => Config::golden_with(&how.sets)?,
        };
        let trace = self.trace.as_deref().map(|path| TraceArgs {
            path,
            config: name,
            overrides: how.sets.clone(),
            every: self.every,
            from: self.from,
            until: self.until,
            states: self.states,
        });
        let steps = (self.steps, self.flow_steps.unwrap_or(self.steps));
        steps_arg("--steps", steps.0)?;
        steps_arg("--flow-steps", steps.1)?;
        let tau = tau_arg(self.tau)?;
        let grains = config.scenario.bed.grains();
        if let Some(w) = long_steps_warning("mbs digest", steps.0.saturating_add(steps.1), grains) {
            print_err(&format!("warning: {w}"));
        }
        digest(&config, steps, self.precision, tau, trace)
    }
}

/// The digest run of a scenario: settling, then the flow.
struct DigestJob {
    scenario: Scenario,
    tau_star: f64,
    steps: (u64, u64),
}

impl SimJob for DigestJob {
    type Output = Result<(u64, u64), mbs_kernel::Error>;

    fn run<R: Real, const N: usize>(self, sim: &mut HostSim<R, N>) -> Self::Output {
        self.scenario
            .digests(sim, self.tau_star, self.steps.0, self.steps.1)
    }
}

/// What `mbs digest --trace` records besides the digests: the file, the
/// configuration's name, and the records' spacing, span and states.
#[derive(Debug, Clone)]
pub struct TraceArgs<'a> {
    /// The trace file to write.
    pub path: &'a Path,
    /// The configuration file's name, `None` for the golden run.
    pub config: Option<String>,
    /// The `--set` overrides on top of it.
    pub overrides: Vec<String>,
    /// Steps between records.
    pub every: u64,
    /// The first recorded step.
    pub from: u64,
    /// The last step run (`None`: both phases).
    pub until: Option<u64>,
    /// Records carry the whole kernel state.
    pub states: bool,
}

/// `mbs digest`: state digests after `steps.0` settling steps and
/// `steps.1` flow steps at τ* — what a board run is compared with; with
/// `trace`, also writes the trace of that run ([`crate::tools::trace`]).
pub fn digest(
    config: &Config,
    steps: (u64, u64),
    precision: Precision,
    tau_star: f64,
    trace: Option<TraceArgs<'_>>,
) -> Result<(), HostError> {
    if let Some(t) = trace {
        let configuration =
            toml::to_string(&canonical(&config.file)).map_err(|e| HostError::Io {
                path: t.path.to_path_buf(),
                error: std::io::Error::other(e),
            })?;
        let run = crate::tools::trace::TraceRun {
            scenario: config.scenario_at(config.seeds[0]),
            capacity: config.capacity,
            spec: crate::tools::trace::TraceSpec {
                config: t.config,
                overrides: t.overrides,
                configuration,
                tau_star,
                settle_steps: steps.0,
                flow_steps: steps.1,
                every: t.every,
                from: t.from,
                until: t.until.unwrap_or(u64::MAX),
                states: t.states,
                precision,
            },
        };
        run.spec.validate()?;
        if let Err(allowed) = run.fits() {
            return Err(crate::config::ConfigError::Invalid {
                key: "--every".into(),
                value: t.every.to_string(),
                allowed,
            }
            .into());
        }
        let trace = run.run().map_err(trace_error("digest trace"))?;
        let text = crate::tools::trace::to_text(&trace).map_err(|e| HostError::Io {
            path: t.path.to_path_buf(),
            error: e.into(),
        })?;
        write_text(t.path, &text)?;
    }
    let job = DigestJob {
        scenario: config.scenario_at(config.seeds[0]),
        tau_star,
        steps,
    };
    let (settled, flow) = with_sim(precision, config.capacity, job)
        .map_err(HostError::kernel(format!("digest, tau* = {tau_star}")))?;
    print(&format!("settling {settled:#018x}\nflow {flow:#018x}\n"))
}

/// A trace run's error as the command's: the kernel's (exit 1), a nudge
/// that cannot be applied (exit 2, `--nudge`), a trace whose state cannot
/// start the run (exit 2, refused).
fn trace_error(what: &'static str) -> impl Fn(crate::tools::trace::RunError) -> HostError {
    move |e| match e {
        crate::tools::trace::RunError::Kernel(e) => HostError::kernel(what.to_string())(e),
        crate::tools::trace::RunError::Nudge(nudge, e) => crate::ConfigError::Invalid {
            key: "--nudge".into(),
            value: nudge.to_string(),
            allowed: format!(
                "an existing grain and a value that stays finite and inside the domain (here {e})"
            ),
        }
        .into(),
        crate::tools::trace::RunError::State(message) => HostError::Trace {
            path: what.into(),
            message,
        },
    }
}

/// `mbs digest --check FILE [--nudge N]`: re-runs the trace's scenario
/// (changing one value by `nudge`, if given) and compares every record; a
/// mismatch is located ([`crate::tools::trace::check`]) and reported as
/// [`HostError::Mismatch`] (exit 1); a damaged, edited, truncated or
/// foreign trace, or one whose configuration no longer gives its scenario,
/// is refused ([`HostError::Trace`], exit 2).
pub fn check_trace(
    path: &Path,
    nudge: Option<crate::tools::trace::Nudge>,
) -> Result<(), HostError> {
    let refuse = |message: String| HostError::Trace {
        path: path.to_path_buf(),
        message,
    };
    let text = read_text_bounded(path, TRACE_BOUND).map_err(|e| match e.kind() {
        std::io::ErrorKind::InvalidData => refuse(e.to_string()),
        _ => HostError::io(path)(e),
    })?;
    let recorded = crate::tools::trace::parse(&text).map_err(refuse)?;
    // The trace's own configuration, checked like a file; it names no
    // file that would be read (a measured profile is only drawn).
    let mut file: ConfigFile = toml::from_str(&recorded.spec.configuration).map_err(|e| {
        refuse(format!(
            "its configuration: {}",
            shown(e.message().to_string())
        ))
    })?;
    file.run.measured_profiles = None;
    let config = Config::validate(file).map_err(|e| refuse(format!("its configuration: {e}")))?;
    recorded
        .spec
        .validate()
        .map_err(|e| refuse(format!("it records a run the command line refuses: {e}")))?;
    if let Some(n) = nudge.filter(|n| n.step > recorded.last_step()) {
        return Err(crate::ConfigError::Invalid {
            key: "--nudge".into(),
            value: n.to_string(),
            allowed: format!(
                "a STEP at most the trace's last record, step {} (a later change is never compared)",
                recorded.last_step()
            ),
        }
        .into());
    }
    let run = crate::tools::trace::TraceRun {
        scenario: config.scenario_at(config.seeds[0]),
        capacity: config.capacity,
        // The check compares digests; it keeps no states of its own.
        spec: crate::tools::trace::TraceSpec {
            states: false,
            ..recorded.spec.clone()
        },
    };
    if let Err(allowed) = run.fits() {
        return Err(refuse(format!(
            "it records a run the command line refuses: --every = {}: must be {allowed}",
            run.spec.every
        )));
    }
    let hash = format!("{:#018x}", run.scenario_hash());
    if hash != recorded.scenario_hash {
        return Err(refuse(format!(
            "its scenario hash is {}, its configuration gives {hash} with this program \
             ({}): the two derive the scenario differently (recorded by {})",
            recorded.scenario_hash,
            env!("CARGO_PKG_VERSION"),
            recorded.program_name()
        )));
    }
    let verdict = crate::tools::trace::check(&run, &recorded, nudge).map_err(|e| match e {
        crate::tools::trace::RunError::State(message) => refuse(message),
        e => trace_error("digest --check")(e),
    })?;
    match verdict {
        crate::tools::trace::Verdict::Mismatch(message) => Err(HostError::Mismatch(message)),
        crate::tools::trace::Verdict::Matches(records, last) => print(&format!(
            "trace matches: {records} records, steps {} to {last}\n",
            recorded.spec.from
        )),
    }
}
