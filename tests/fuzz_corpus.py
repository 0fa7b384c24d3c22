"""The fuzz corpus the tests use: one small input per defect that fuzzing found, and the command
that showed it, with what ncsim must do now.

Every file is written by this module (``python tests/fuzz_corpus.py`` regenerates
``tests/fuzz/``); they are ours, modelled on the reproducers of the fuzzing campaign, not copies
of them. ``tests/test_fuzz_corpus.py`` checks that the committed files are what this module
writes and runs every case through the CLI. Ids follow the campaign's table: T tracebacks,
W silent wrong numbers, S green on nothing, U unclear messages, G CSV readers, P plausibility
(a value in the wrong unit), C command-line options, D other dialects and ISO mode.
"""
from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

HERE = Path(__file__).resolve().parent
CORPUS = HERE / "fuzz"

#: the paper's MIKRON (Table 1, sec. 5.2.4 and 5.3.2), without comments
BASE_MACHINE = {
    "machine": {"name": "fuzz-mikron"},
    "axes.X": {"max_velocity_m_min": 30.0, "max_accel_m_s2": 2.5, "max_jerk_m_s3": 5.0},
    "axes.Y": {"max_velocity_m_min": 30.0, "max_accel_m_s2": 3.0, "max_jerk_m_s3": 5.0},
    "axes.Z": {"max_velocity_m_min": 30.0, "max_accel_m_s2": 2.1, "max_jerk_m_s3": 50.0},
    "ncu": {"ipo_cycle_ms": 12.0, "curvilinear_jerk_m_s3": 10.0, "tangential_jerk_share": 0.6,
            "central_jerk_share": 0.4, "transition_time_ms": 12.0, "lookahead_blocks": 100,
            "exact_stop_fine_settle_ms": 24.0, "exact_stop_coarse_settle_ms": 12.0},
}


def machine_toml(comment: str = "", **changes: str) -> str:
    """The base machine with ``table__key="TOML value"`` changes, the table's dots written as
    underscores (``axes_X__max_jerk_m_s3="1e-300"``)."""
    out = [f"# {comment}"] if comment else []
    for table, keys in BASE_MACHINE.items():
        out += ["", f"[{table}]"]
        prefix = table.replace(".", "_") + "__"
        for key, value in keys.items():
            text = f'"{value}"' if isinstance(value, str) else repr(value)
            out.append(f"{key} = {changes.pop(prefix + key, text)}")
    assert not changes, changes
    return "\n".join(out).lstrip("\n") + "\n"


PROGRAM = "G17 G90 G64\nG1 X10 F1000\nG3 X10 Y0 I-5 J0\nG0 Z5\nM30\n"
TRACE_HEAD = "t_s,x_mm,y_mm,z_mm,feed_mm_min\n"
TRACE_ROWS = ["0.000,0.000,0.000,0.000,0.0", "0.012,0.001,0.000,0.000,10.0",
              "0.024,0.004,0.000,0.000,20.0", "0.036,0.009,0.000,0.000,30.0"]

FILES: dict[str, bytes] = {
    "ok.mpf": PROGRAM.encode(),
    "base.toml": machine_toml("the paper's MIKRON").encode(),
    # T: tracebacks
    "T1_div_overflow.mpf": ("R1=1000000000\nR2=" + "*".join(["R1"] * 34) + " DIV 0.0001\nM30\n").encode(),
    "T2_long_word.mpf": ("G1 X1 F100\n" + "POCKET" + "Q" * 294 + "\nM30\n").encode(),
    "T3_machine_latin1.toml": machine_toml("Fr\xe4ser").encode("latin-1"),
    "T4_setup_latin1.toml": "# Fr\xe4ser\n[work_offsets]\nG54 = [0.0, 0.0, 0.0]\n".encode("latin-1"),
    "T5_machine_jerk_tiny.toml": machine_toml(axes_X__max_jerk_m_s3="1e-300").encode(),
    "T6_machine_lookahead_huge.toml": machine_toml(ncu__lookahead_blocks="99999999999999999999").encode(),
    # W: silent wrong numbers
    "W1_machine_g54_nan.toml": (machine_toml() + "\n[work_offsets]\nG54 = [nan, 0.0, 0.0]\n").encode(),
    "W1_machine_g54_inf.toml": (machine_toml() + "\n[work_offsets]\nG54 = [inf, 0.0, 0.0]\n").encode(),
    "W1_uses_g54.mpf": b"G54 G90 G1 X10 F1000\nM30\n",
    "W2_cr_only.mpf": b"N10 G1 X10 F1000 ; first cut\rN20 G1 X0 Y50\rN30 G1 Z-5\rM30\r",
    "W3_machine_velocity_denormal.toml": machine_toml(axes_X__max_velocity_m_min="5e-324").encode(),
    "W3_machine_settle_huge.toml": machine_toml(ncu__exact_stop_fine_settle_ms="1e300").encode(),
    "W5_phantom_rapid.mpf": b"G17 G90 G60\nG1 F6000 X1 Y-2.07486 Z3.356451\nAROT Z=63.418\n"
                            b"G0 X=IC(0)\nG1 Y-1 Z0.002\nM30\n",
    "W5_reference.mpf": b"G17 G90 G60\nG1 F6000 X1 Y-2.07486 Z3.356451\nAROT Z=63.418\n"
                        b"G1 Y-1 Z0.002\nM30\n",
    # S: green on nothing
    "S1_empty.mpf": b"",
    "S1_comments_only.mpf": b"; CAM post-processor output\n; tool T1 D10\n",
    "S1_truncated.mpf": PROGRAM.rsplit("G0", 1)[0].encode(),
    "S3_setup_G054.toml": b"[work_offsets]\nG054 = [100.0, 0.0, 0.0]\n",
    # U: messages
    "U3_bom.mpf": b"\xef\xbb\xbf" + PROGRAM.encode(),
    "U3_setup_offset_1e160.toml": b"[work_offsets]\nG54 = [1e160, 0.0, 0.0]\n",
    # G: the CSV readers
    "G3_trace_decimal_comma.csv": (TRACE_HEAD + "\n".join(TRACE_ROWS[:2] + ["0.024,0,004,0.000,0.000,20.0"]
                                                         + TRACE_ROWS[3:]) + "\n").encode(),
    "G3_trace_underscore.csv": (TRACE_HEAD + "\n".join(TRACE_ROWS[:2] + ["0.024,1_000,0.000,0.000,20.0"]
                                                      + TRACE_ROWS[3:]) + "\n").encode(),
    "G4_trace_ok.csv": (TRACE_HEAD + "\n".join(TRACE_ROWS) + "\n").encode(),
    # D: other dialects (Fanuc/ISO code, LinuxCNC code) and ISO mode's own mistakes
    "D1_fanuc.nc": b"%\nO1234 (PART)\nG21 G90 G17\nG0 X0 Y0 Z10.\nG81 X5. Y5. Z-2. R1. F100\n"
                   b"G80\nM30\n%\n",
    "D2_linuxcnc.ngc": b"(probe)\n#<depth> = -2\no100 sub\nG1 Z#<depth> F100\no100 endsub\n"
                       b"o100 call\nM2\n",
    "D3_iso_unclosed_loop.nc": b"O1\n#1=0\nWHILE [#1 LT 3] DO 1\n#1=#1+1\nM30\n",
    "D4_iso_bad_expression.nc": b"O1\n#1=[2+*3]\nM30\n",
    "D5_iso_alarm.nc": b"O1\n#3000=12 (TOOL BROKEN)\nM30\n",
    # P: plausibility
    "P1_machine_velocity_mm_min.toml": machine_toml(axes_Y__max_velocity_m_min="30000.0").encode(),
    "P2_machine_jerk_mm_s3.toml": machine_toml(axes_X__max_jerk_m_s3="5000.0").encode(),
}


@dataclass(frozen=True)
class Case:
    """``ncsim ARGV`` run in the corpus folder: its exit status, its stderr lines (regular
    expressions, matched in full) and optionally a regular expression its stdout contains."""

    id: str
    argv: tuple[str, ...]
    exit: int
    stderr: tuple[str, ...] = ()
    stdout: str | None = None
    needs: tuple[str, ...] = field(default=())     # paths that must exist (e.g. /dev/full)


def _one_line(pattern: str) -> tuple[str, ...]:
    return (pattern,)


MIKRON = ("-m", "base.toml")
CASES = [
    Case("T1 overflowing DIV", ("run", "T1_div_overflow.mpf", *MIKRON), 2,
         _one_line(r"T1_div_overflow\.mpf:2:\d+: result of 1e\+306 DIV 0\.0001 is out of the range of a REAL")),
    Case("T2 word too long for a file name", ("run", "T2_long_word.mpf", *MIKRON), 2,
         _one_line(r"T2_long_word\.mpf:2:1: subprogram POCKETQ+\.\.\.Q+ \(300 characters\) not found: "
                   r"no PROC POCKETQ+\.\.\.Q+ \(300 characters\) and no .*")),
    Case("T3 machine file not UTF-8", ("run", "ok.mpf", "-m", "T3_machine_latin1.toml"), 2,
         _one_line(r"T3_machine_latin1\.toml: cannot read machine file: not UTF-8 text \(byte 0xe4 at line 1, column 5\)")),
    Case("T4 setup file not UTF-8", ("run", "ok.mpf", *MIKRON, "--setup", "T4_setup_latin1.toml"), 2,
         _one_line(r"T4_setup_latin1\.toml: cannot read setup file: not UTF-8 text \(byte 0xe4 at line 1, column 5\)")),
    Case("T5 jerk of 1e-300", ("run", "ok.mpf", "-m", "T5_machine_jerk_tiny.toml"), 2,
         _one_line(r"T5_machine_jerk_tiny\.toml: axes\.X\.max_jerk_m_s3: must be between 0\.001 and 1e\+09 m/s\^3, got 1e-300")),
    Case("T6 look-ahead of 2^63 and more", ("run", "ok.mpf", "-m", "T6_machine_lookahead_huge.toml"), 2,
         _one_line(r"T6_machine_lookahead_huge\.toml: ncu\.lookahead_blocks: must be an integer from 1 to 100000, "
                   r"got 99999999999999999999")),
    Case("T7 full disk while writing the trace", ("run", "ok.mpf", *MIKRON, "--trace", "/dev/full"), 2,
         _one_line(r"ncsim run: error: /dev/full: cannot write trace file: No space left on device"),
         needs=("/dev/full",)),
    Case("W1 NaN work offset", ("run", "W1_uses_g54.mpf", "-m", "W1_machine_g54_nan.toml", "--json"), 2,
         _one_line(r"W1_machine_g54_nan\.toml: work_offsets\.G54: must be three finite numbers .*got \[nan, 0, 0\]")),
    Case("W1 infinite work offset", ("run", "W1_uses_g54.mpf", "-m", "W1_machine_g54_inf.toml", "--json"), 2,
         _one_line(r"W1_machine_g54_inf\.toml: work_offsets\.G54: must be three finite numbers .*got \[inf, 0, 0\]")),
    Case("W2 CR-only line ends", ("parse", "W2_cr_only.mpf"), 0, (),
         r"segments: 3 \(3 lines, 0 arcs\)  total length: 65\.990 mm  blocks executed: 4"),
    Case("W3 denormal velocity", ("run", "ok.mpf", "-m", "W3_machine_velocity_denormal.toml", "--json"), 2,
         _one_line(r"W3_machine_velocity_denormal\.toml: axes\.X\.max_velocity_m_min: must be between 0\.001 and "
                   r"1e\+06 m/min, got 4\.94066e-324")),
    Case("W3 huge settle time", ("run", "ok.mpf", "-m", "W3_machine_settle_huge.toml", "--json"), 2,
         _one_line(r"W3_machine_settle_huge\.toml: ncu\.exact_stop_fine_settle_ms: must be between 0 and 100000 ms, "
                   r"got 1e\+300")),
    Case("W5 a rapid that rounds to nothing", ("run", "W5_phantom_rapid.mpf", *MIKRON), 0, (),
         r"cycle time  0\.234 s .*\n(?:.*\n)*path        7\.5 mm in 2 blocks"),
    Case("W5 reference", ("run", "W5_reference.mpf", *MIKRON), 0, (),
         r"cycle time  0\.234 s .*\n(?:.*\n)*path        7\.5 mm in 2 blocks"),
    Case("S1 empty program fails check", ("check", "S1_empty.mpf", *MIKRON, "--max-time", "1"), 1,
         (r"S1_empty\.mpf: warning: the program ends without M30, M2 or M17 \(truncated\?\)",
          r"S1_empty\.mpf: warning: no motion: the program moves no axis"),
         r"FAIL  program: no motion and no M30, M2 or M17 at the end \(truncated\?\)"),
    Case("S1 comments-only program fails check",
         ("check", "S1_comments_only.mpf", *MIKRON, "--max-time", "1", "--min-feed-ratio", "0.9"), 1,
         (r"S1_comments_only\.mpf:2:1: warning: the program ends without M30, M2 or M17 \(truncated\?\)",
          r"S1_comments_only\.mpf: warning: no motion: the program moves no axis"),
         r"FAIL  program: no motion and no M30.*\n.*\nPASS  feed ratio.*\n1 of 3 checks failed"),
    Case("S1 truncated program fails check", ("check", "S1_truncated.mpf", *MIKRON, "--max-time", "100"), 1,
         _one_line(r"S1_truncated\.mpf:3:1: warning: the program ends without M30, M2 or M17 \(truncated\?\)"),
         r"FAIL  program: no M30, M2 or M17 at the end \(truncated\?\)"),
    Case("S1 truncated program warns in run", ("run", "S1_truncated.mpf", *MIKRON), 0,
         _one_line(r"S1_truncated\.mpf:3:1: warning: the program ends without M30, M2 or M17 \(truncated\?\)")),
    Case("S1 --allow-empty", ("check", "S1_empty.mpf", *MIKRON, "--max-time", "1", "--allow-empty"), 0,
         (r"S1_empty\.mpf: warning: .*", r"S1_empty\.mpf: warning: .*"), r"\n1 check passed\n$"),
    Case("S3 setup key G054", ("run", "ok.mpf", *MIKRON, "--setup", "S3_setup_G054.toml"), 2,
         _one_line(r"S3_setup_G054\.toml: work_offsets\.G054: unknown work offset \(write G54; use G54\.\.G57 or "
                   r"G505\.\.G599\)")),
    Case("U1 missing program", ("run", "missing.mpf", *MIKRON), 2,
         _one_line(r"missing\.mpf: cannot read program: No such file or directory")),
    Case("U2 unknown option of ncsim", ("--badopt",), 2,
         _one_line(r"ncsim: error: No such option '--badopt'\. \(see 'ncsim --help'\)")),
    Case("U3 byte-order mark", ("run", "U3_bom.mpf", *MIKRON), 0, (), r"cycle time"),
    Case("U3 work offset of 1e160", ("run", "ok.mpf", *MIKRON, "--setup", "U3_setup_offset_1e160.toml"), 2,
         _one_line(r"U3_setup_offset_1e160\.toml: work_offsets\.G54: must be three finite numbers of magnitude "
                   r"below 1e\+09 mm \(the 840D's position range\), got \[1e\+160, 0, 0\]")),
    Case("U4 one check passed", ("check", "ok.mpf", *MIKRON, "--max-time", "100"), 0, (),
         r"\nPASS  cycle time .*\n1 check passed\n$"),
    Case("G3 decimal comma, gap", ("gap", "ok.mpf", "--machine", "base.toml", "--measured", "G3_trace_decimal_comma.csv"), 2,
         _one_line(r"G3_trace_decimal_comma\.csv:4: row has 6 fields, the header has 5 \(a decimal comma\?\)")),
    Case("G3 decimal comma, plot", ("plot", "--trace", "G3_trace_decimal_comma.csv", "-o", "never.png"), 2,
         _one_line(r"G3_trace_decimal_comma\.csv:4: row has 6 fields, the header has 5 \(a decimal comma\?\)")),
    Case("G3 underscore, gap", ("gap", "ok.mpf", "--machine", "base.toml", "--measured", "G3_trace_underscore.csv"), 2,
         _one_line(r"G3_trace_underscore\.csv:4: column 'x_mm' is not a number: '1_000'")),
    Case("G3 underscore, plot", ("plot", "--trace", "G3_trace_underscore.csv", "-o", "never.png"), 2,
         _one_line(r"G3_trace_underscore\.csv:4: column 'x_mm' is not a number: '1_000'")),
    Case("G4 sample period over a time column", ("gap", "ok.mpf", "--machine", "base.toml", "--measured",
                                                 "G4_trace_ok.csv", "--sample-period-ms", "2"), 2,
         _one_line(r"ncsim gap: error: G4_trace_ok\.csv: has a time column 't_s': a sample period is for files "
                   r"without one")),
    Case("C1 --max-time nan", ("check", "ok.mpf", *MIKRON, "--max-time", "nan"), 2,
         _one_line(r"ncsim check: error: Invalid value for '--max-time': 'nan' is not a finite number\. .*")),
    Case("C2 --trace ''", ("run", "ok.mpf", *MIKRON, "--trace", ""), 2,
         _one_line(r"ncsim run: error: Invalid value for '--trace': the file name is empty\. .*")),
    Case("D1 a Fanuc program in Siemens mode", ("run", "D1_fanuc.nc", *MIKRON), 2,
         _one_line(r"D1_fanuc\.nc:2:1: looks like ISO/Fanuc code \(O1234, G81, G80\): run with --dialect iso")),
    Case("D1 the same with --dialect iso", ("run", "D1_fanuc.nc", *MIKRON, "--dialect", "iso"), 0, (),
         r"path        \d+\.\d mm in 5 blocks"),
    Case("D2 a LinuxCNC program", ("run", "D2_linuxcnc.ngc", *MIKRON, "--dialect", "iso"), 2,
         _one_line(r"D2_linuxcnc\.ngc:2:1: looks like LinuxCNC/RS274NGC code \(#<depth>, o100 sub, o100 endsub\): "
                   r"not an 840D program")),
    Case("D3 DO without END", ("run", "D3_iso_unclosed_loop.nc", *MIKRON, "--dialect", "iso"), 2,
         _one_line(r"D3_iso_unclosed_loop\.nc:3:1: DO 1 without END 1")),
    Case("D4 a bad expression", ("run", "D4_iso_bad_expression.nc", *MIKRON, "--dialect", "iso"), 2,
         _one_line(r"D4_iso_bad_expression\.nc:2:7: unexpected '\*' in an expression")),
    Case("D5 macro alarm", ("run", "D5_iso_alarm.nc", *MIKRON, "--dialect", "iso"), 2,
         _one_line(r"D5_iso_alarm\.nc:2:1: #3000 = 12: macro alarm 12, the control stops the program here")),
    Case("P1 velocity in mm/min", ("run", "ok.mpf", "-m", "P1_machine_velocity_mm_min.toml"), 0,
         _one_line(r"P1_machine_velocity_mm_min\.toml: axes\.Y\.max_velocity_m_min: warning: 30000 m/min is outside "
                   r"the usual 0\.5\.\.300 m/min \(in mm/min\? that is 30 m/min\)")),
    Case("P2 jerk 1000x off", ("run", "ok.mpf", "-m", "P2_machine_jerk_mm_s3.toml"), 0,
         _one_line(r"P2_machine_jerk_mm_s3\.toml: axes\.X\.max_jerk_m_s3: warning: 5000 m/s\^3 is over 100 times "
                   r"every other jerk .*\(.*in mm/s\^3\? that is 5 m/s\^3\)")),
]


def write(folder: Path = CORPUS) -> None:
    """Write the corpus into ``folder`` (created), replacing what is there."""
    folder.mkdir(parents=True, exist_ok=True)
    for old in folder.iterdir():
        if old.name not in FILES:
            old.unlink()
    for name, data in FILES.items():
        (folder / name).write_bytes(data)


if __name__ == "__main__":
    write()
    print(f"wrote {len(FILES)} files to {CORPUS}")
