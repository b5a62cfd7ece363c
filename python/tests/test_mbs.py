"""The Python package against the command line: the same checks, the same
bits, the same guarantees (issue 43). Run with ``pytest python/tests``
after ``pip install ./python``; the command line is taken from
``MBS_BIN`` or the repository's ``target/release/mbs``."""

import gc
import os
import signal
import subprocess
import threading
from pathlib import Path

import numpy as np
import pytest

import mbs

ROOT = Path(__file__).resolve().parents[2]
BIN = Path(os.environ.get("MBS_BIN", ROOT / "target" / "release" / "mbs"))

# A bed small and short enough for a test (as the host suite's SMALL).
SMALL = {
    "bed.columns": 5,
    "bed.rows": 4,
    "time.settle": 0.05,
    "time.spin_up": 0.02,
    "time.window": 0.05,
    "time.window_min": 0.05,
    "time.block": 0.005,
    "flow.tau_star": [0.1, 0.3],
    "run.seeds": [1, 2],
    "run.capacity": 256,
}


def small(**more):
    return mbs.Config().set({**SMALL, **more})


def cli(*args):
    return subprocess.run([str(BIN), "--quiet", *map(str, args)], capture_output=True, text=True)


def test_config_is_checked_as_set():
    c = mbs.Config()
    assert c.tau_stars == [0.03, 0.06, 0.1, 0.2, 0.4]
    c.set("flow.tau_star", [0.1, 0.2]).set("run.precision", "f32")
    assert c.tau_stars == [0.1, 0.2]
    assert 'precision = "f32"' in c.to_toml()
    with pytest.raises(mbs.ConfigError) as e:
        c.set("flow.kappa", 2.0)
    assert isinstance(e.value, ValueError)
    assert "flow.kappa = 2: must be in [0.1, 1]" in str(e.value)
    assert c.tau_stars == [0.1, 0.2], "a refused value changes nothing"
    with pytest.raises(mbs.ConfigError, match="unknown field `no_such_key`"):
        c.set("flow.no_such_key", 1)
    with pytest.raises(mbs.ConfigError, match="No such file"):
        mbs.Config("/no/such/case.toml")


def test_run_gives_the_command_lines_table_byte_for_byte(tmp_path):
    c = small()
    (tmp_path / "small.toml").write_text(c.to_toml())
    results = mbs.run(c, out=tmp_path / "py", threads=1)
    assert cli("run", tmp_path / "small.toml", "--out", tmp_path / "cli").returncode == 0
    assert (tmp_path / "py" / "transport.csv").read_bytes() == (tmp_path / "cli" / "transport.csv").read_bytes()
    t = results.transport
    assert list(t["tau_star"]) == [0.1, 0.3]
    assert results.summary["cells_reused"] == 0
    assert len(results.timeseries) > 0 and len(results.profiles) > 0
    # Threads change no bit.
    mbs.run(c, out=tmp_path / "two", threads=2)
    assert (tmp_path / "two" / "transport.csv").read_bytes() == (tmp_path / "py" / "transport.csv").read_bytes()
    # A rerun reuses every cell.
    again = mbs.run(c, out=tmp_path / "py")
    assert again.summary["cells_reused"] == 4


def test_a_sim_cell_is_the_runs_cell(tmp_path):
    c = small()
    results = mbs.run(c.copy().set("flow.tau_star", [0.3]).set("run.seeds", [2]), out=tmp_path / "r")
    sim = mbs.Sim(c, tau_star=0.3, seed=2)
    cell = sim.run_cell()
    assert cell["q_star"] == results.transport["q_star"][0], "the same q*, bit for bit"
    # Settling twice gives the same bits; stepping, checkpoint and restore continue them.
    a, b = mbs.Sim(c, 0.3, 2), mbs.Sim(c, 0.3, 2)
    assert a.settle() in ("AtRest", "NotAtRest")
    b.settle()
    assert a.digest() == b.digest()
    a.step(200)
    saved = a.checkpoint()
    a.step(200)
    restored = mbs.Sim.restore(saved, c, 0.3, 2)
    restored.step(200)
    assert restored.digest() == a.digest()
    assert restored.step_count == a.step_count
    with pytest.raises(mbs.SimulationError, match="checkpoint refused"):
        mbs.Sim.restore(saved[:100], c, 0.3, 2)


def test_arrays_are_copies_that_outlive_the_sim():
    sim = mbs.Sim(small(), 0.3, 1)
    sim.settle()
    g = sim.grains()
    contacts = sim.contacts()
    x = g["x"].copy()
    del sim
    gc.collect()
    assert np.array_equal(g["x"], x)
    assert g["fixed"].dtype == bool and g["fixed"].sum() > 0
    assert set(g) == {"x", "y", "u", "v", "spin", "radius", "fixed", "class"}
    assert len(contacts["i"]) == len(contacts["fx"]) > 0
    assert np.all(g["radius"] > 0)


def test_progress_and_profiles(tmp_path, capsys):
    pytest.importorskip("tqdm")
    mbs.run(small(), out=tmp_path / "p", progress=True)
    assert "mbs run" in capsys.readouterr().err, "a tqdm bar"
    sim = mbs.Sim(small(), 0.3, 1)
    sim.settle()
    p = sim.profile()
    assert set(p) >= {"y_over_d", "solid_fraction", "grain_velocity_m_s", "fluid_velocity_m_s"}
    n = len(p["y_over_d"])
    assert n > 10 and all(len(v) == n for v in p.values())
    assert np.all(np.diff(p["y_over_d"]) > 0)
    assert 0.3 < p["solid_fraction"].max() <= 1.0
    # In the bed (y ≈ 1 d) the grains are packed; far above it there are none.
    assert p["solid_fraction"][np.argmin(abs(p["y_over_d"] - 1.0))] > 0.3
    assert p["solid_fraction"][-1] == 0.0


def test_errors_are_python_exceptions():
    with pytest.raises(mbs.ConfigError, match=r"tau_star = 9: must be in \(0, 5\]"):
        mbs.Sim(small(), tau_star=9.0)
    with pytest.raises(mbs.ConfigError, match="--threads = 2000"):
        mbs.run(small(), out="/tmp/never", threads=2000)
    with pytest.raises(mbs.ConfigError, match="must be a directory"):
        mbs.run(small(), out="/dev/null")


def test_keyboard_interrupt_checkpoints_and_resume_finishes_the_same_table(tmp_path):
    c = small(**{"time.window": 2.0, "time.window_min": 2.0})
    reference = mbs.run(c, out=tmp_path / "reference")
    timer = threading.Timer(0.5, lambda: os.kill(os.getpid(), signal.SIGINT))
    timer.start()
    with pytest.raises(KeyboardInterrupt):
        mbs.run(c, out=tmp_path / "stopped")
    timer.join()
    assert any((tmp_path / "stopped" / "checkpoints").iterdir()), "running cells checkpointed"
    resumed = mbs.run(resume=tmp_path / "stopped")
    assert (resumed.dir / "transport.csv").read_bytes() == (reference.dir / "transport.csv").read_bytes()
