"""The reproducers of the third fuzzing campaign (``../shared/data/fuzz-repro-s3``, README
table: file, command, expected, got), read in place: every one gives the README's expected
result. Tracebacks become one line with exit status 2 (machine files the kernels cannot
compute, TOML nested too deeply, gap inputs beyond any recording, devices and named pipes,
memory exhaustion); the silent wrong numbers are errors or right numbers; hangs end.

W1, M1-M3 and S1 (the compressor and corner rounding) are tested with the HSM modes."""
from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import threading
import time

import pytest
from click.testing import CliRunner

from ncsim.cli.main import cli

LINUX = sys.platform.startswith("linux")


@pytest.fixture
def repro(shared, monkeypatch):
    folder = shared / "data" / "fuzz-repro-s3"
    monkeypatch.chdir(folder)
    return folder


def invoke(*args, seconds: float = 60.0):
    """``ncsim ARGS`` in this process; a run that does not return within ``seconds`` (blocked
    on a named pipe) fails the test instead of hanging it."""
    done = {}
    worker = threading.Thread(target=lambda: done.setdefault(
        "r", CliRunner().invoke(cli, [str(a) for a in args])), daemon=True)
    worker.start()
    worker.join(seconds)
    assert "r" in done, f"ncsim {' '.join(map(str, args))} still runs after {seconds} s"
    return done["r"]


def one_line(r, exit_code: int = 2) -> str:
    """The single stderr line of a run that failed as it should (no traceback, no stdout)."""
    assert r.exit_code == exit_code, r.output
    assert "Traceback" not in r.output and r.stdout == ""
    lines = r.stderr.splitlines()
    assert len(lines) == 1, lines
    return lines[0]


# ---- W: silent wrong numbers ------------------------------------------------------------------

def test_w2_drive_reduction_to_nothing_is_refused_with_its_reason(repro):
    """MD35230 = 1 leaves (1 - 1) A = 0 m/s^2 at the axis velocity: the block that runs there
    could never be reached (it gave a -0.024 s block and NaN warnings)."""
    line = one_line(invoke("run", "W2_prog_drive.mpf", "--machine",
                          "W2_machine_drive_full_reduction.toml", "--json"))
    assert line.startswith("W2_machine_drive_full_reduction.toml: ncu.drive_accel_reduction_ratio: "
                           "DRIVE keeps (1 - 1) of the acceleration at the maximum velocity")


def test_w3_the_g0_g1_stop_window_is_in_the_identity(repro):
    r = invoke("run", "bore.mpf", "--machine", "W3_machine_g0_g1_stop_window.toml", "--json")
    assert r.exit_code == 0, r.output
    s = json.loads(r.stdout)
    assert s["ideal_time_s"] + s["lost_time_s"] + s["dwell_time_s"] == pytest.approx(
        s["cycle_time_s"], rel=1e-12)
    exact = [c for c in s["lost_by_cause"] if c["cause"] == "exact_stop"]
    assert sum(c["settle_s"] for c in exact) == pytest.approx(2 * 0.024, rel=1e-12)   # 2 x G601


def test_w4_a_zero_radius_circle_is_an_error_with_and_without_a_frame(repro, tmp_path):
    text = (repro / "W4_zero_radius_circle.mpf").read_text()
    without = tmp_path / "W4_without_frame.mpf"
    without.write_text("".join(ln for ln in text.splitlines(True) if not ln.startswith("ROT")))
    for program, line in ((repro / "W4_zero_radius_circle.mpf", 6), (without, 5)):
        r = invoke("run", program, "--machine", "mikron", "--json")
        assert r.exit_code == 2 and r.stdout == ""
        assert r.stderr.splitlines()[-1] == f"{program}:{line}:6: circle centre coincides with the start point"


# ---- T: tracebacks ----------------------------------------------------------------------------

def test_t1_a_tangential_jerk_share_of_1e_300(repro):
    line = one_line(invoke("run", "bore.mpf", "--machine", "T1_machine_tangential_jerk_share_tiny.toml"))
    assert line.startswith("T1_machine_tangential_jerk_share_tiny.toml: ncu.tangential_jerk_share: "
                           "gives J_tcurv = curvilinear_jerk_m_s3 x tangential_jerk_share = 1e-299 m/s^3")


def test_t2_a_slow_axis_with_drive_reduction_to_nothing(repro):
    r = invoke("run", "W2_prog_drive.mpf", "--machine", "T2_machine_drive_full_reduction_slow_y.toml")
    assert r.exit_code == 2 and "Traceback" not in r.output and "RuntimeWarning" not in r.output
    assert r.stderr.splitlines()[-1].startswith(
        "T2_machine_drive_full_reduction_slow_y.toml: ncu.drive_accel_reduction_ratio: ")


@pytest.mark.parametrize("command", [("run", "bore.mpf"), ("explain",)])
def test_t3_toml_nested_5000_deep(repro, command):
    line = one_line(invoke(*command, "--machine", "T3_machine_deep_array.toml"))
    assert line.startswith("T3_machine_deep_array.toml: not valid TOML: arrays or inline tables "
                           "nested too deeply")


@pytest.mark.parametrize("trace, expected", [
    ("T4_trace_x_1e300.csv", "T4_trace_x_1e300.csv:12: column 'x_mm' holds 1e+300 mm, beyond +-1e+09"),
    ("T4_trace_time_1e-300_steps.csv", "T4_trace_time_1e-300_steps.csv: the samples are 4e-303 s "
                                       "apart (the median time step), under 1 us"),
])
def test_t4_gap_on_values_no_recording_has(repro, trace, expected):
    assert one_line(invoke("gap", "bore.mpf", "--machine", "mikron", "--measured", trace)).startswith(expected)


def test_t4_gap_with_a_sample_period_of_1e_300_ms(repro, tmp_path):
    untimed = tmp_path / "untimed.csv"
    rows = (repro / "T4_trace_x_1e300.csv").read_text().splitlines()[:11]   # before the 1e300
    untimed.write_text("\n".join(r.split(",", 1)[1] for r in rows) + "\n")
    line = one_line(invoke("gap", "bore.mpf", "--machine", "mikron", "--measured", untimed, "--sample-period-ms", "1e-300"))
    assert line.startswith("ncsim gap: error: the sample period must be at least 1 us")


@pytest.mark.skipif(not os.path.exists("/dev/zero"), reason="needs /dev/zero")
@pytest.mark.parametrize("args, what", [
    (("run", "/dev/zero", "--machine", "mikron"), "program"),
    (("run", "bore.mpf", "--machine", "/dev/zero"), "machine file"),
    (("run", "bore.mpf", "--machine", "mikron", "--setup", "/dev/zero"), "setup file"),
    (("gap", "bore.mpf", "--machine", "mikron", "--measured", "/dev/zero"), "file"),
])
def test_t5_a_device_is_refused_before_reading(repro, args, what):
    assert one_line(invoke(*args, seconds=20)) == \
        f"/dev/zero: cannot read {what}: a character device, not a regular file"


def test_t5_running_out_of_memory_is_one_line(repro, monkeypatch):
    """Wherever the memory runs out, one line naming the program and the stage."""
    import ncsim.pipeline

    def exhausted(*args, **kwargs):
        raise MemoryError("Unable to allocate 83.9 MiB for an array with shape (11000000,)")
    monkeypatch.setattr(ncsim.pipeline, "interpret_file", exhausted)
    assert one_line(invoke("run", "bore.mpf", "--machine", "mikron")) == (
        "bore.mpf: out of memory while interpreting it (unable to allocate 83.9 MiB): the input "
        "is too large for the memory this process may use")


@pytest.mark.skipif(not LINUX, reason="RLIMIT_AS and /proc/self/status (Linux)")
def test_t5_a_program_too_large_for_a_memory_limit(tmp_path):
    """A real limit (as ``ulimit -v``): 60 MB above what the process holds after its imports,
    and a 600,000-block program (11 MB) whose columns need more."""
    program = tmp_path / "large.mpf"
    program.write_text("G17 G90 G64\nG1 F6000\n" + "".join(
        f"X{i * 0.01:.2f} Y{(i % 7) * 0.1:.1f}\n" for i in range(600_000)) + "M30\n")
    code = ("import resource, sys\n"
            "from ncsim.cli.main import cli\n"
            "import numpy, lark\n"
            "size = next(int(ln.split()[1]) * 1024 for ln in open('/proc/self/status')\n"
            "            if ln.startswith('VmSize:'))\n"
            "resource.setrlimit(resource.RLIMIT_AS, (size + 60 * 2**20, resource.RLIM_INFINITY))\n"
            "cli.main(['run', sys.argv[1], '--machine', 'mikron'], prog_name='ncsim')\n")
    r = subprocess.run([sys.executable, "-c", code, str(program)], capture_output=True, text=True,
                       timeout=300, env={**os.environ, "NCSIM_KERNELS": "python"})
    lines = r.stderr.splitlines()
    assert r.returncode == 2 and len(lines) == 1 and "Traceback" not in r.stderr, r.stderr
    assert "out of memory" in lines[0]


# ---- H: hangs ---------------------------------------------------------------------------------

@pytest.fixture
def fifo(tmp_path):
    if not hasattr(os, "mkfifo"):
        pytest.skip("no named pipes here")
    path = tmp_path / "f.mpf"
    os.mkfifo(path)
    return path


@pytest.mark.parametrize("args, what", [
    (("run", "{fifo}", "--machine", "mikron"), "program"),
    (("run", "{bore}", "--machine", "{fifo}"), "machine file"),
    (("run", "{bore}", "--machine", "mikron", "--setup", "{fifo}"), "setup file"),
    (("run", "{bore}", "--machine", "mikron", "--definitions", "{fifo}"), "definitions file"),
    (("gap", "{bore}", "--machine", "mikron", "--measured", "{fifo}"), "file"),
    (("plot", "--trace", "{fifo}", "-o", "{tmp}/never.png"), "trace file"),
])
def test_h1_a_named_pipe_is_refused_before_reading(repro, fifo, tmp_path, args, what):
    args = [a.format(fifo=fifo, bore=repro / "bore.mpf", tmp=tmp_path) for a in args]
    assert one_line(invoke(*args, seconds=30)) == \
        f"{fifo}: cannot read {what}: a named pipe (FIFO), not a regular file"


def test_h1_batch_reports_a_named_pipe_and_goes_on(repro, fifo, tmp_path):
    (tmp_path / "bore.mpf").write_text((repro / "bore.mpf").read_text())
    r = invoke("batch", str(tmp_path / "*.mpf"), "--machine", "mikron", "-j", "2", seconds=120)
    assert r.exit_code == 2
    assert r.stderr.strip() == f"{fifo}: cannot read program: a named pipe (FIFO), not a regular file"
    assert "1/2 programs simulated" in r.stdout


def _children(pid: int) -> list[int]:
    """The processes whose parent is ``pid`` (from /proc)."""
    found = []
    for entry in os.listdir("/proc"):
        if entry.isdigit():
            try:
                with open(f"/proc/{entry}/stat") as fh:
                    ppid = int(fh.read().rsplit(")", 1)[1].split()[1])
            except (OSError, ValueError, IndexError):
                continue
            if ppid == pid:
                found.append(int(entry))
    return found


def _gone(pids, seconds: float) -> bool:
    end = time.monotonic() + seconds
    while time.monotonic() < end:
        if not any(os.path.exists(f"/proc/{p}") for p in pids):
            return True
        time.sleep(0.1)
    return False


@pytest.mark.skipif(not LINUX, reason="reads /proc")
@pytest.mark.parametrize("stop", [signal.SIGINT, signal.SIGKILL], ids=["interrupted", "killed"])
def test_h1_batch_workers_end_with_the_batch(tmp_path, stop):
    """Two programs that run for minutes (long FOR loops); the batch is interrupted (Ctrl-C:
    exit 130) or killed: its worker processes end with it, none is left running."""
    for name in ("a.mpf", "b.mpf"):
        (tmp_path / name).write_text("R2=0\nFOR R1=1 TO 100000000\nR2=R2+1\nENDFOR\nM30\n")
    batch = subprocess.Popen([sys.executable, "-m", "ncsim", "batch", str(tmp_path / "*.mpf"),
                              "--machine", "mikron", "-j", "2"],
                             stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    workers = []
    try:
        end = time.monotonic() + 60
        while len(workers) < 2 and time.monotonic() < end:
            workers = _children(batch.pid)
            time.sleep(0.1)
        assert len(workers) >= 2, "the batch started no workers"
        time.sleep(0.5)                          # the workers run their programs
        batch.send_signal(stop)
        _, err = batch.communicate(timeout=60)
        assert batch.returncode == (130 if stop == signal.SIGINT else -signal.SIGKILL), err
        if stop == signal.SIGINT:
            assert err.strip() == "ncsim: interrupted"
        assert _gone(workers, 10.0), f"workers {workers} still run"
    finally:
        for pid in [batch.pid, *workers]:
            try:
                os.kill(pid, signal.SIGKILL)
            except OSError:
                pass
        batch.wait()


# ---- U: unclear messages ----------------------------------------------------------------------

def test_u1_the_end_of_the_program_is_located_at_column_1(repro):
    r = invoke("run", "U1_no_m30.mpf", "--machine", "mikron")
    assert r.exit_code == 0
    assert r.stderr.splitlines() == [
        "U1_no_m30.mpf:1:1: warning: the program ends without M30, M2 or M17 (truncated?)"]


def test_u2_a_20000_digit_token_is_shown_abbreviated(repro):
    line = one_line(invoke("run", "U2_long_token.mpf", "--machine", "mikron"))
    assert line.startswith("U2_long_token.mpf:2:4: unexpected number '1.00000")
    assert line.endswith("01 (20,003 characters)'") and len(line) < 120
