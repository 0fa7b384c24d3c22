"""`ncsim batch`: local processes and a local Dask cluster give the same answers."""
from __future__ import annotations

import json

import pytest
from click.testing import CliRunner

from ncsim.pipeline import expand_programs, run_batch, simulate_one
from ncsim.cli.batch import batch
from ncsim.errors import UsageError
from ncsim.pipeline import simulate

PROGRAMS = ["programs/circle_r2p5_f6000.mpf", "programs/circle_r30_f9000.mpf",
            "programs/spiral_semi_f6000.mpf"]


@pytest.fixture(autouse=True)
def _repo_cwd(repo_root, monkeypatch):
    monkeypatch.chdir(repo_root)


def test_batch_matches_single_runs(mikron):
    results = run_batch(PROGRAMS, mikron, jobs=2)
    assert [r.program for r in results] == PROGRAMS
    for r in results:
        assert r.ok, r.error
        assert r.cycle_time_s == pytest.approx(simulate(r.program, mikron).cycle_time_s, rel=1e-12)


def test_batch_reports_a_bad_program_without_stopping(tmp_path, mikron):
    bad = tmp_path / "bad.mpf"
    bad.write_text("G1 X10 Y10\n")  # no feed ever set
    results = run_batch([PROGRAMS[0], str(bad)], mikron, jobs=1)
    assert results[0].ok
    assert not results[1].ok and str(bad) in results[1].error and ":1:" in results[1].error


def test_cli_batch_json_and_exit_codes(tmp_path):
    runner = CliRunner()
    res = runner.invoke(batch, ["programs/circle_r30_*.mpf", "--machine", "mikron", "-j", "2", "--json"])
    assert res.exit_code == 0, res.output
    data = json.loads(res.output)
    assert len(data["results"]) == 4 and all(r["ok"] for r in data["results"])
    bad = tmp_path / "bad.mpf"
    bad.write_text("G1 X10 F100\nG2 X20\n")  # arc with no centre or radius
    res = runner.invoke(batch, [str(bad), "--machine", "mikron", "-j", "1"])
    assert res.exit_code == 2
    assert f"{bad}:2:" in res.output


def test_no_match_is_a_usage_error():
    with pytest.raises(UsageError, match="no program matches"):
        expand_programs(["programs/does_not_exist_*.mpf"])


def _job_with_a_subprogram(folder):
    """A main program calling a subprogram file beside it, and a file it does not call."""
    folder.mkdir()
    (folder / "main.mpf").write_text("G17 G90 G64 F6000\nG1 X5\nPOCKET_A\nG0 Z5\nM30\n")
    (folder / "POCKET_A.SPF").write_text("G1 X10 Y5\nG2 X10 Y5 I-5 J0\nM17\n")
    (folder / "UNUSED.SPF").write_text("this is not even a program\n")


def _local_cluster():
    """Two worker processes; the scheduler's HTTP server (started even without a dashboard, at
    8787 by default) on a free port, so that clusters of concurrent test runs do not collide."""
    import distributed
    return distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True,
                                    dashboard_address="127.0.0.1:0")


def test_dask_workers_elsewhere_get_the_program_text(mikron, tmp_path, monkeypatch):
    """Workers started in another folder (as on other machines) cannot read the client's
    relative paths: they get each program, and the subprograms it calls, as text."""
    from ncsim.pipeline import program_source

    elsewhere = tmp_path / "worker_home"
    elsewhere.mkdir()
    monkeypatch.chdir(elsewhere)        # the workers start here ...
    with _local_cluster() as cluster:
        monkeypatch.chdir(tmp_path)     # ... the client reads from here
        _job_with_a_subprogram(tmp_path / "job")
        jobs = ["job/main.mpf", "job/missing.mpf"]
        dask_results = run_batch(jobs, mikron, scheduler=cluster.scheduler_address)
    assert [r.program for r in dask_results] == jobs
    local = simulate_one("job/main.mpf", mikron)
    assert local.ok and dask_results[0].ok, dask_results[0].error
    assert dask_results[0].cycle_time_s == pytest.approx(local.cycle_time_s, rel=1e-12)
    assert not dask_results[1].ok and dask_results[1].error.startswith("job/missing.mpf: cannot read")
    assert set(program_source("job/main.mpf").subprograms) == {"POCKET_A.SPF"}


def test_dask_local_cluster_gives_the_same_results(mikron):
    with _local_cluster() as cluster:
        dask_results = run_batch(PROGRAMS, mikron, scheduler=cluster.scheduler_address)
    local = [simulate_one(p, mikron) for p in PROGRAMS]
    assert [r.program for r in dask_results] == PROGRAMS
    for d, loc in zip(dask_results, local):
        assert d.ok and d.cycle_time_s == pytest.approx(loc.cycle_time_s, rel=1e-12)
    assert len({r.worker for r in dask_results}) >= 1


def test_an_error_in_a_sent_subprogram_names_it_as_the_client_knows_it(mikron, tmp_path,
                                                                        monkeypatch):
    from ncsim.pipeline import program_source, simulate_source

    monkeypatch.chdir(tmp_path)
    _job_with_a_subprogram(tmp_path / "job")
    (tmp_path / "job" / "POCKET_A.SPF").write_text("G1 X10 Y5\nG2 X20\nM17\n")   # no centre
    source = program_source("job/main.mpf")
    monkeypatch.chdir(tmp_path / "job")   # the worker runs elsewhere
    result = simulate_source(source, mikron)
    assert not result.ok and result.error.startswith("job/POCKET_A.SPF:2:"), result.error


def test_jobs_must_be_positive(mikron):
    with pytest.raises(UsageError, match="--jobs must be at least 1"):
        run_batch(PROGRAMS, mikron, jobs=0)
    from ncsim.cli.main import cli

    res = CliRunner().invoke(cli, ["batch", PROGRAMS[0], "--machine", "mikron", "--jobs", "0"])
    assert res.exit_code == 2 and res.output == "ncsim batch: error: --jobs must be at least 1\n"
