"""The JSON summary's schema ships in the package and every summary follows it (an unknown
key or a wrong type fails: update ``ncsim/report/summary.schema.json`` with the README)."""
from __future__ import annotations

import json

import jsonschema
import pytest
from click.testing import CliRunner

from ncsim.cli.main import cli
from ncsim.report.jsonout import schema

THWS = "data/real/thws-spinner-u5-620-nc-programs/Bottle_opener_Flaschenoeffner.txt"


@pytest.fixture(scope="module")
def validator():
    s = schema()
    jsonschema.Draft202012Validator.check_schema(s)
    return jsonschema.Draft202012Validator(s)


def _run(*args) -> dict:
    r = CliRunner().invoke(cli, ["run", *args, "-m", "mikron", "--json", "-q"])
    assert r.exit_code == 0, r.output
    return json.loads(r.stdout)


def test_summaries_follow_the_schema(validator, repo_root, shared):
    bore = _run(str(repo_root / "programs" / "bore_d25_f5984.mpf"), "--crosscheck")
    assert bore["blocks_detail"] and bore["crosscheck"]
    validator.validate(bore)
    validator.validate(_run(str(shared / THWS), "--no-blocks"))
    empty = _run(str(repo_root / "programs" / "bore_d25_f5984.mpf"), "--top", "0", "--no-blocks")
    validator.validate(empty)


def test_the_schema_rejects_drift(validator, repo_root):
    s = _run(str(repo_root / "programs" / "bore_d25_f5984.mpf"), "--no-blocks")
    for broken in ({**s, "new_key": 1}, {**s, "cycle_time_s": "2.1"},
                   {**s, "by_tool": [{**s["by_tool"][0], "lost_to": "slow"}]},
                   {k: v for k, v in s.items() if k != "by_operation"}):
        with pytest.raises(jsonschema.ValidationError):
            validator.validate(broken)
