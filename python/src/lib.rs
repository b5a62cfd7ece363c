//! `mbs._mbs`: the Python package's native module, a thin layer over the
//! host library (`mbs`): the configuration as the command line checks it,
//! the main job as `mbs run` runs it, and one bed held between calls
//! (`mbs::work::session::Session`). No physics and no checks of its own:
//! every value goes through the same code as the command line.

use mbs::work::session::Session;
use pyo3::create_exception;
use pyo3::exceptions::{PyKeyboardInterrupt, PyRuntimeError, PyValueError};
use pyo3::prelude::*;
use pyo3::types::{PyBytes, PyDict};
use std::path::PathBuf;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::Duration;

create_exception!(
    _mbs,
    ConfigError,
    PyValueError,
    "A configuration value out of its range, an unknown key, a bad file: the command line's exit status 2."
);
create_exception!(
    _mbs,
    SimulationError,
    PyRuntimeError,
    "A numerical failure, an unusable output directory, a damaged checkpoint: the command line's exit status 1."
);

/// The host's error as the Python exception of its exit status.
fn py_err(e: mbs::HostError) -> PyErr {
    match e.exit_code() {
        2 => ConfigError::new_err(e.to_string()),
        130 => PyKeyboardInterrupt::new_err(e.to_string()),
        _ => SimulationError::new_err(e.to_string()),
    }
}

/// A configuration: the embedded default or a file, with `--set`
/// overrides, checked exactly as the command line checks it.
#[pyclass(module = "mbs._mbs", name = "NativeConfig")]
#[derive(Clone)]
struct NativeConfig {
    path: Option<PathBuf>,
    sets: Vec<String>,
    config: mbs::Config,
}

#[pymethods]
impl NativeConfig {
    #[new]
    #[pyo3(signature = (path=None))]
    fn new(path: Option<PathBuf>) -> PyResult<Self> {
        let config = mbs::Config::load_with(path.as_deref(), &[]).map_err(|e| py_err(e.into()))?;
        Ok(NativeConfig {
            path,
            sets: Vec::new(),
            config,
        })
    }

    /// `--set KEY=VALUE` for each (key, TOML value), checked together as
    /// one command line's; on error nothing changes.
    fn set(&mut self, pairs: Vec<(String, String)>) -> PyResult<()> {
        let mut sets = self.sets.clone();
        sets.extend(pairs.iter().map(|(k, v)| format!("{k}={v}")));
        let config =
            mbs::Config::load_with(self.path.as_deref(), &sets).map_err(|e| py_err(e.into()))?;
        (self.sets, self.config) = (sets, config);
        Ok(())
    }

    /// The configuration as `DIR/config.toml` holds it: every default.
    fn to_toml(&self) -> PyResult<String> {
        toml::to_string(&self.config.file).map_err(|e| ConfigError::new_err(e.to_string()))
    }

    /// The `--set` overrides applied, in order.
    #[getter]
    fn sets(&self) -> Vec<String> {
        self.sets.clone()
    }

    /// Shields numbers.
    #[getter]
    fn tau_stars(&self) -> Vec<f64> {
        self.config.tau_stars.clone()
    }

    /// Seeds.
    #[getter]
    fn seeds(&self) -> Vec<u64> {
        self.config.seeds.clone()
    }

    /// The output directory of `run.output`.
    #[getter]
    fn output(&self) -> PathBuf {
        self.config.output.clone()
    }

    fn __copy__(&self) -> Self {
        self.clone()
    }
}

/// Set by the main thread on KeyboardInterrupt: the running cells
/// checkpoint and stop, as on Ctrl-C.
static STOP: AtomicBool = AtomicBool::new(false);

/// The running job's progress bar, handed over by `mbs::cli::run`.
static BAR: std::sync::Mutex<Option<mbs::indicatif::ProgressBar>> = std::sync::Mutex::new(None);

/// Calls `on_progress(done, total)` with the bar's steps, if both are there.
fn report_progress(py: Python<'_>, on_progress: Option<&PyObject>) -> PyResult<()> {
    let Some(f) = on_progress else {
        return Ok(());
    };
    let state = BAR
        .lock()
        .ok()
        .and_then(|b| b.as_ref().map(|b| (b.position(), b.length())));
    if let Some((done, Some(total))) = state {
        f.call1(py, (done, total))?;
    }
    Ok(())
}

/// Runs `job` on another thread with the GIL released, checking Python's
/// signals every 0.1 s: a KeyboardInterrupt sets [`STOP`], waits for the
/// job to checkpoint and raises KeyboardInterrupt.
fn interruptible(
    py: Python<'_>,
    on_progress: Option<&PyObject>,
    job: impl FnOnce() -> Result<(), mbs::HostError> + Send + 'static,
) -> PyResult<()> {
    STOP.store(false, Ordering::Relaxed);
    if let Ok(mut bar) = BAR.lock() {
        *bar = None;
    }
    let (tx, rx) = std::sync::mpsc::channel();
    let rx = std::sync::Mutex::new(rx);
    std::thread::spawn(move || {
        let _ = tx.send(job());
    });
    let mut interrupted: Option<PyErr> = None;
    loop {
        let got = py.allow_threads(|| match rx.lock() {
            Ok(rx) => rx.recv_timeout(Duration::from_millis(100)),
            Err(_) => Err(std::sync::mpsc::RecvTimeoutError::Disconnected),
        });
        match got {
            Ok(result) => {
                report_progress(py, on_progress)?;
                return match (interrupted, result) {
                    (Some(e), _) => Err(e),
                    (None, r) => r.map_err(py_err),
                };
            }
            Err(std::sync::mpsc::RecvTimeoutError::Disconnected) => {
                return Err(SimulationError::new_err(
                    "the run's thread ended without a result",
                ));
            }
            Err(std::sync::mpsc::RecvTimeoutError::Timeout) => {
                if interrupted.is_none() {
                    if let Err(e) = report_progress(py, on_progress) {
                        STOP.store(true, Ordering::Relaxed);
                        interrupted = Some(e);
                        continue;
                    }
                    if let Err(e) = py.check_signals() {
                        STOP.store(true, Ordering::Relaxed);
                        interrupted = Some(e);
                    }
                }
            }
        }
    }
}

/// `mbs run`: the main job into `out` (or `run.output`), with the command
/// line's store, resume, lock and log; resuming `resume` (a directory)
/// with the configuration it started with. Returns the output directory.
#[pyfunction]
#[pyo3(signature = (config=None, out=None, threads=0, resume=None, quiet=true, on_progress=None))]
fn run(
    py: Python<'_>,
    config: Option<NativeConfig>,
    out: Option<PathBuf>,
    threads: usize,
    resume: Option<PathBuf>,
    quiet: bool,
    on_progress: Option<PyObject>,
) -> PyResult<PathBuf> {
    mbs::cli::check_threads(threads).map_err(py_err)?;
    let (config, out, resuming) = match resume {
        Some(dir) => (
            mbs::cli::resumed_config(&dir).map_err(py_err)?,
            Some(dir),
            true,
        ),
        None => {
            let c = match config {
                Some(c) => c.config,
                None => mbs::Config::load(None).map_err(|e| py_err(e.into()))?,
            };
            (c, out, false)
        }
    };
    let dir = out.clone().unwrap_or_else(|| config.output.clone());
    let options = mbs::cli::RunOptions {
        resuming,
        stop: Some(&STOP),
        progress_to: Some(&BAR),
        ..mbs::cli::RunOptions::default()
    };
    let common = mbs::cli::Common { quiet, threads };
    interruptible(py, on_progress.as_ref(), move || {
        mbs::cli::run(&config, out.as_deref(), options, common)
    })?;
    Ok(dir)
}

/// One (τ*, seed) bed held between calls (`mbs::work::session::Session`).
#[pyclass(module = "mbs._mbs", name = "NativeSim")]
struct NativeSim {
    session: Session,
}

/// `values` as the bytes of little-endian f64 (numpy reads them).
fn f64_bytes<'py>(py: Python<'py>, values: &[f64]) -> Bound<'py, PyBytes> {
    let bytes: Vec<u8> = values.iter().flat_map(|v| v.to_le_bytes()).collect();
    PyBytes::new(py, &bytes)
}

#[pymethods]
impl NativeSim {
    #[new]
    fn new(config: &NativeConfig, tau_star: f64, seed: u64) -> PyResult<Self> {
        let session = Session::new(&config.config, tau_star, seed).map_err(py_err)?;
        Ok(NativeSim { session })
    }

    /// Settles as `mbs run` settles the seed's bed and starts the flow;
    /// returns the bed's status (`AtRest`, `NotAtRest`).
    fn settle(&mut self, py: Python<'_>) -> PyResult<String> {
        let session = &mut self.session;
        let status = py.allow_threads(|| session.settle()).map_err(py_err)?;
        Ok(format!("{status:?}"))
    }

    /// Runs `n` integration steps (the GIL released).
    fn step(&mut self, py: Python<'_>, n: u64) -> PyResult<()> {
        let session = &mut self.session;
        py.allow_threads(|| session.step(n)).map_err(py_err)
    }

    /// The whole cell of `mbs run` for this τ* and seed: its result as a
    /// dict (q*, per class, window, discarded transient, …).
    fn run_cell<'py>(&mut self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        let session = &mut self.session;
        let r = py.allow_threads(|| session.run_cell()).map_err(py_err)?;
        let d = PyDict::new(py);
        d.set_item("tau_star", r.tau_star)?;
        d.set_item("seed", r.seed)?;
        d.set_item("q_star", r.q_star)?;
        d.set_item("q_star_class", r.q_star_class.clone())?;
        d.set_item("window_s", r.window_s)?;
        d.set_item("discarded_blocks", r.discarded)?;
        d.set_item("steady", r.steady)?;
        d.set_item("target_reached", r.target_reached)?;
        d.set_item("bed_level_m", r.bed_level)?;
        d.set_item(
            "block_q_star",
            r.blocks.iter().map(|b| b.q_star).collect::<Vec<f64>>(),
        )?;
        Ok(d)
    }

    #[getter]
    fn time(&self) -> f64 {
        self.session.time()
    }

    #[getter]
    fn step_count(&self) -> u64 {
        self.session.step_count()
    }

    #[getter]
    fn tau_star(&self) -> f64 {
        self.session.tau_star()
    }

    #[getter]
    fn seed(&self) -> u64 {
        self.session.seed()
    }

    /// Every grain's values: f64 bytes per field, `fixed` and `class` as
    /// one byte each.
    fn grains<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        let g = self.session.grains();
        let d = PyDict::new(py);
        for (name, values) in [
            ("x", &g.x),
            ("y", &g.y),
            ("u", &g.u),
            ("v", &g.v),
            ("spin", &g.spin),
            ("radius", &g.radius),
        ] {
            d.set_item(name, f64_bytes(py, values))?;
        }
        let fixed: Vec<u8> = g.fixed.iter().map(|&f| u8::from(f)).collect();
        d.set_item("fixed", PyBytes::new(py, &fixed))?;
        d.set_item("class", PyBytes::new(py, &g.class))?;
        Ok(d)
    }

    /// Every contact: grains i, j (u64 bytes) and the force on i (f64 bytes).
    fn contacts<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        let c = self.session.contacts();
        let d = PyDict::new(py);
        let index =
            |v: &[usize]| -> Vec<u8> { v.iter().flat_map(|&i| (i as u64).to_le_bytes()).collect() };
        d.set_item("i", PyBytes::new(py, &index(&c.i)))?;
        d.set_item("j", PyBytes::new(py, &index(&c.j)))?;
        d.set_item("fx", f64_bytes(py, &c.fx))?;
        d.set_item("fy", f64_bytes(py, &c.fy))?;
        Ok(d)
    }

    /// q* now, as a window samples it.
    fn q_star(&self) -> f64 {
        self.session.q_star()
    }

    /// The profiles now: y/d of each cell's centre, φ, u_p, u_f and the
    /// shear stresses (f64 bytes each).
    fn profile<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        let p = self.session.profile().map_err(py_err)?;
        let d = PyDict::new(py);
        d.set_item("y_over_d", f64_bytes(py, &self.session.profile_heights_d()))?;
        d.set_item("solid_fraction", f64_bytes(py, &p.solid_fraction))?;
        d.set_item("grain_velocity_m_s", f64_bytes(py, &p.grain_velocity))?;
        d.set_item("fluid_velocity_m_s", f64_bytes(py, &p.fluid_velocity))?;
        let [contact, kinetic, viscous, reynolds] = p.stresses.columns();
        d.set_item("contact_stress_pa", f64_bytes(py, contact))?;
        d.set_item("kinetic_stress_pa", f64_bytes(py, kinetic))?;
        d.set_item("viscous_stress_pa", f64_bytes(py, viscous))?;
        d.set_item("reynolds_stress_pa", f64_bytes(py, reynolds))?;
        Ok(d)
    }

    /// The state digest.
    fn digest(&self) -> u64 {
        self.session.digest()
    }

    /// The kernel checkpoint.
    fn checkpoint<'py>(&self, py: Python<'py>) -> Bound<'py, PyBytes> {
        PyBytes::new(py, &self.session.checkpoint())
    }

    /// Continues from a checkpoint; refused (nothing changed) if damaged.
    fn restore(&mut self, bytes: &[u8]) -> PyResult<()> {
        self.session.restore(bytes).map_err(py_err)
    }
}

/// The native module.
#[pymodule]
fn _mbs(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_class::<NativeConfig>()?;
    m.add_class::<NativeSim>()?;
    m.add_function(wrap_pyfunction!(run, m)?)?;
    m.add("ConfigError", m.py().get_type::<ConfigError>())?;
    m.add("SimulationError", m.py().get_type::<SimulationError>())?;
    m.add("__version__", env!("CARGO_PKG_VERSION"))?;
    Ok(())
}
