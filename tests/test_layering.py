"""The package layout keeps its walls: checked by reading every module's imports (``ast``).

One package per stage of the data flow (``docs/architecture.md``):

* ``ncsim.nc`` (program text -> Path) imports none of ``plan``, ``report``, ``gap``, ``cli``;
* ``ncsim.plan`` (Path -> Motion) imports none of ``gap``, ``cli``;
* ``ncsim.report`` (what a run prints and writes) imports none of ``gap``, ``cli``: the gap
  diagnosis reports through it, never the other way (the CSV reader both use is
  ``ncsim.config``'s);
* ``ncsim.gap.truth`` (the validation truths) is imported only by itself, tests and benchmarks;
* no module imports another module's private name (``from x import _y``, ``x._y``), nor a
  private module (``_kernels``) of another package;
* no module is longer than ``MAX_MODULE_LINES``, no class longer than ``MAX_CLASS_LINES``.

Imports inside functions count as much as those at the top. Each rule is shown to fail on a
small synthetic package (``test_each_rule_catches_its_violation``).
"""
from __future__ import annotations

import ast
from dataclasses import dataclass
from pathlib import Path

import pytest

MAX_MODULE_LINES = 800
MAX_CLASS_LINES = 400

#: package -> packages it must not import (a package covers its subpackages)
FORBIDDEN = {
    "ncsim.nc": ("ncsim.plan", "ncsim.report", "ncsim.gap", "ncsim.cli"),
    "ncsim.plan": ("ncsim.gap", "ncsim.cli"),
    "ncsim.report": ("ncsim.gap", "ncsim.cli"),
}
#: imported by nothing in ncsim outside itself (tests and benchmarks may)
FENCED = ("ncsim.gap.truth",)

#: modules allowed over the size limits, each with the reason (none at present)
SIZE_EXCEPTIONS: dict[str, str] = {}


@dataclass(frozen=True)
class Module:
    name: str          # dotted, e.g. ncsim.plan.lookahead
    source: str
    is_package: bool   # an __init__.py


@dataclass(frozen=True)
class Import:
    line: int
    module: str        # the imported module (resolved, absolute)
    name: str | None   # the name taken from it (``from module import name``), or None


def _within(module: str, package: str) -> bool:
    return module == package or module.startswith(package + ".")


def _package_of(mod: Module) -> str:
    return mod.name if mod.is_package else mod.name.rpartition(".")[0]


def _private(part: str) -> bool:
    return part.startswith("_") and not (part.startswith("__") and part.endswith("__"))


def imports_of(mod: Module, known: set[str]) -> list[Import]:
    """Every import of ``mod`` (any depth in the tree), resolved against the known modules:
    ``from p import m`` where ``p.m`` is a module imports ``p.m``."""
    out = []
    for node in ast.walk(ast.parse(mod.source)):
        if isinstance(node, ast.Import):
            out += [Import(node.lineno, a.name, None) for a in node.names]
        elif isinstance(node, ast.ImportFrom):
            base = node.module or ""
            if node.level:
                anchor = _package_of(mod).split(".")
                anchor = anchor[:len(anchor) - (node.level - 1)]
                base = ".".join(anchor + ([base] if base else []))
            for a in node.names:
                sub = f"{base}.{a.name}"
                out.append(Import(node.lineno, sub, None) if sub in known
                           else Import(node.lineno, base, a.name))
    return out


def private_attribute_uses(mod: Module, known: set[str]) -> list[tuple[int, str]]:
    """``alias._name`` where ``alias`` is bound to another ncsim module by an import."""
    tree = ast.parse(mod.source)
    bound: dict[str, str] = {}
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            for a in node.names:
                if a.asname:
                    bound[a.asname] = a.name
                else:
                    bound[a.name.split(".")[0]] = a.name.split(".")[0]
        elif isinstance(node, ast.ImportFrom):
            for imp in imports_of(Module(mod.name, ast.unparse(node), mod.is_package), known):
                if imp.name is None:
                    alias = next(a for a in node.names if imp.module.endswith("." + a.name))
                    bound[alias.asname or alias.name] = imp.module
    out = []
    for node in ast.walk(tree):
        if not isinstance(node, ast.Attribute) or not _private(node.attr):
            continue
        chain, value = [node.attr], node.value
        while isinstance(value, ast.Attribute):
            chain.append(value.attr)
            value = value.value
        if isinstance(value, ast.Name) and value.id in bound:
            target = ".".join([bound[value.id], *reversed(chain[1:])])
            if target in known and target != mod.name:
                out.append((node.lineno, f"{target}.{node.attr}"))
    return out


def violations(modules: list[Module]) -> list[str]:
    """Every broken rule of the module docstring, one line each: ``module:line: what``."""
    known = {m.name for m in modules}
    found = []
    for mod in modules:
        for imp in imports_of(mod, known):
            if not _within(imp.module, "ncsim"):
                continue
            for package, banned in FORBIDDEN.items():
                for b in banned:
                    if _within(mod.name, package) and _within(imp.module, b):
                        found.append(f"{mod.name}:{imp.line}: {package} imports {imp.module}")
            for fence in FENCED:
                if _within(imp.module, fence) and not _within(mod.name, fence):
                    found.append(f"{mod.name}:{imp.line}: imports {imp.module} "
                                 "(tests and benchmarks only)")
            if imp.name is not None and _private(imp.name) and imp.module != mod.name:
                found.append(f"{mod.name}:{imp.line}: imports the private name "
                             f"{imp.module}.{imp.name}")
            parts = imp.module.split(".")
            owner = ".".join(parts[:-1])
            if _private(parts[-1]) and not _within(_package_of(mod), owner):
                found.append(f"{mod.name}:{imp.line}: imports the private module {imp.module}")
        for line, what in private_attribute_uses(mod, known):
            found.append(f"{mod.name}:{line}: uses the private name {what}")
        if mod.name in SIZE_EXCEPTIONS:
            continue
        n_lines = len(mod.source.splitlines())
        if n_lines > MAX_MODULE_LINES:
            found.append(f"{mod.name}: {n_lines} lines (at most {MAX_MODULE_LINES})")
        for node in ast.walk(ast.parse(mod.source)):
            if isinstance(node, ast.ClassDef):
                size = node.end_lineno - node.lineno + 1
                if size > MAX_CLASS_LINES:
                    found.append(f"{mod.name}:{node.lineno}: class {node.name} has {size} lines "
                                 f"(at most {MAX_CLASS_LINES})")
    return found


def package_modules(root: Path) -> list[Module]:
    """Every module of the ``ncsim`` package below ``root`` (the repository)."""
    out = []
    for file in sorted((root / "ncsim").rglob("*.py")):
        rel = file.relative_to(root).with_suffix("")
        parts = list(rel.parts)
        is_package = parts[-1] == "__init__"
        if is_package:
            parts = parts[:-1]
        out.append(Module(".".join(parts), file.read_text(encoding="utf-8"), is_package))
    return out


def test_the_package_keeps_its_walls(repo_root):
    modules = package_modules(repo_root)
    names = {m.name for m in modules}
    assert {"ncsim.nc.interpret", "ncsim.plan.lookahead", "ncsim.gap.truth.servo",
            "ncsim.cli.main"} <= names          # the walk found the package
    assert violations(modules) == []


def test_size_exceptions_are_still_needed(repo_root):
    """An exception that no longer applies is removed (it would hide a regression)."""
    modules = {m.name: m for m in package_modules(repo_root)}
    for name in SIZE_EXCEPTIONS:
        if name not in modules:
            continue
        mod = modules[name]
        classes = [n for n in ast.walk(ast.parse(mod.source)) if isinstance(n, ast.ClassDef)]
        too_long = (len(mod.source.splitlines()) > MAX_MODULE_LINES
                    or any(c.end_lineno - c.lineno + 1 > MAX_CLASS_LINES for c in classes))
        assert too_long, f"{name} is within the limits now: remove it from SIZE_EXCEPTIONS"


def test_the_top_level_stays_small(repo_root):
    """The top of the package: shared types, the pipeline in one call, the kernels' compiler
    switch (``jit``, shared by nc, plan and report) and one folder per stage."""
    entries = [p.name for p in (repo_root / "ncsim").iterdir()
               if p.name != "__pycache__" and (p.suffix == ".py" or p.is_dir())]
    assert len(entries) <= 17, sorted(entries)
    assert {"nc", "plan", "report", "gap", "cli"} <= set(entries)


# ---------------------------------------------------------------------------------------------
# The checker fails when a rule is broken
# ---------------------------------------------------------------------------------------------

def _package(**sources: str) -> list[Module]:
    """A synthetic package: keyword ``a__b`` is module ``ncsim.a.b``; packages are implied."""
    mods = {}
    for key, src in sources.items():
        parts = ["ncsim", *key.split("__")]
        for i in range(1, len(parts)):
            pkg = ".".join(parts[:i])
            mods.setdefault(pkg, Module(pkg, "", True))
        mods[".".join(parts)] = Module(".".join(parts), src, False)
    for pkg in ("ncsim.nc", "ncsim.plan", "ncsim.report", "ncsim.gap", "ncsim.gap.truth", "ncsim.cli"):
        mods.setdefault(pkg, Module(pkg, "", True))
    mods.setdefault("ncsim.plan.lookahead", Module("ncsim.plan.lookahead", "def plan(): pass\n", False))
    mods.setdefault("ncsim.plan._kernels", Module("ncsim.plan._kernels", "def k(): pass\n", False))
    mods.setdefault("ncsim.gap.truth.servo", Module("ncsim.gap.truth.servo", "", False))
    return list(mods.values())


CLEAN = dict(
    nc__parse="import numpy as np\nfrom ncsim.path import Path\nfrom ncsim import units\n",
    plan__ramps="from ncsim.plan import _kernels\nfrom ncsim.plan._kernels import k\n",
    gap__truth__cases="from ncsim.gap.truth.servo import simulate_servo\n",
    report__csvio="from ncsim.plan import lookahead\nx = lookahead.plan\n",
)

BROKEN = [
    ("nc imports plan", dict(nc__parse="from ncsim.plan.lookahead import plan\n"),
     "ncsim.nc imports ncsim.plan.lookahead"),
    ("nc imports gap inside a function",
     dict(nc__parse="def f():\n    import ncsim.gap.effects\n"), "ncsim.nc imports ncsim.gap"),
    ("nc imports report, relatively", dict(nc__parse="from ..report import summary\n"),
     "ncsim.nc imports ncsim.report"),
    ("nc imports cli", dict(nc__parse="from ncsim.cli.main import cli\n"), "ncsim.nc imports ncsim.cli"),
    ("plan imports gap", dict(plan__limits="from ncsim.gap import effects\n"),
     "ncsim.plan imports ncsim.gap"),
    ("plan imports cli", dict(plan__limits="import ncsim.cli.main as m\n"), "ncsim.plan imports ncsim.cli"),
    ("report imports gap", dict(report__csvio="from ncsim.gap.measured import MeasuredTrace\n"),
     "ncsim.report imports ncsim.gap.measured"),
    ("report imports cli inside a function",
     dict(report__plot="def f():\n    from ncsim.cli import main\n"), "ncsim.report imports ncsim.cli"),
    ("production code imports the truth",
     dict(gap__servo_part="from ncsim.gap.truth.servo import estimate_lag\n"),
     "imports ncsim.gap.truth.servo (tests and benchmarks only)"),
    ("a private name", dict(gap__plot="from ncsim.gap.diagnose import _compare_speed\n"),
     "imports the private name ncsim.gap.diagnose._compare_speed"),
    ("a private name through an alias",
     dict(report__plot="from ncsim.plan import lookahead as la\nx = la._refine\n"),
     "uses the private name ncsim.plan.lookahead._refine"),
    ("a private name through a dotted import",
     dict(report__plot="import ncsim.plan.lookahead\nx = ncsim.plan.lookahead._refine\n"),
     "uses the private name ncsim.plan.lookahead._refine"),
    ("another package's private module",
     dict(report__csvio="from ncsim.plan._kernels import k\n"),
     "imports the private module ncsim.plan._kernels"),
    ("a module too long", dict(report__big="x = 1\n" * (MAX_MODULE_LINES + 1)),
     f"{MAX_MODULE_LINES + 1} lines"),
    ("a class too long",
     dict(report__big="class Big:\n" + "    x = 1\n" * MAX_CLASS_LINES), "class Big has"),
]


def test_the_checker_passes_a_clean_package():
    assert violations(_package(**CLEAN)) == []


@pytest.mark.parametrize("what, sources, expected", BROKEN, ids=[b[0] for b in BROKEN])
def test_each_rule_catches_its_violation(what, sources, expected):
    found = violations(_package(**{**CLEAN, **sources}))
    assert any(expected in v for v in found), found
