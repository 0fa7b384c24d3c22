"""The JSON summary written as a stream: the per-block list is never held whole.

``ncsim run --json`` on a million blocks wrote a 340 MB text built in memory (a dict per
block, then one string): 2.2 GB. :func:`write_summary` writes the summary's head as indented
JSON, then ``blocks_detail`` one compact line per block, made and written
:data:`CHUNK_BLOCKS` at a time from the columns (``summary.block_rows``), so the memory is the
run's own plus one chunk. ``--no-blocks`` leaves the list out.

The summary's JSON Schema (draft 2020-12) ships with the package, ``summary.schema.json``
beside this module (:func:`schema`); ``tests/test_summary_schema.py`` holds the summaries to it.
"""
from __future__ import annotations

import json
from importlib import resources
from typing import Iterable, TextIO

import numpy as np

from ncsim.report.summary import block_dicts, block_rows

CHUNK_BLOCKS = 1 << 14


def block_chunks(motion, loss, chunk: int = CHUNK_BLOCKS) -> Iterable[list[dict]]:
    """``blocks_detail`` of ``motion``, ``chunk`` blocks at a time."""
    rows = block_rows(motion, loss)
    files = motion.path.files
    for a in range(0, motion.path.n, chunk):
        yield block_dicts(rows, files, np.arange(a, min(a + chunk, motion.path.n)))


def write_summary(stream: TextIO, summary: dict, blocks: Iterable[list[dict]] | None = None) -> None:
    """``summary`` as indented JSON, with ``blocks_detail`` (``summary``'s own list, or the
    chunks ``blocks``) one compact line per block (an indented dump of a million blocks goes
    through Python's slow encoder: 3x the time)."""
    if blocks is None and "blocks_detail" in summary:
        blocks = [summary["blocks_detail"]]
    head = {k: v for k, v in summary.items() if k != "blocks_detail"}
    text = json.dumps(head, indent=1)
    if blocks is None:
        stream.write(text + "\n")
        return
    stream.write(text[:-2] + ',\n "blocks_detail": [')
    encode = json.JSONEncoder().encode
    first = True
    for chunk in blocks:
        if not chunk:
            continue
        stream.write(("\n  " if first else ",\n  ") + ",\n  ".join(encode(b) for b in chunk))
        first = False
    stream.write("]\n}\n" if first else "\n ]\n}\n")


def schema() -> dict:
    """The JSON Schema of the summary (``summary.schema.json``, shipped in the package)."""
    return json.loads((resources.files("ncsim.report") / "summary.schema.json").read_text("utf-8"))
