"""ISO dialect subprograms and macro calls: M98, M99, G65 (SINUMERIK ISO Milling, "Subprogram
call (M98, M99)", "Macro programs": "Macro call (G65)").

* ``M98 P<n> L<k>`` calls program O<n> k times (``P`` of more than four digits without L: the
  first digits are the count, the last four the number); the subprogram shares its caller's
  local variables; ``M99`` returns (``M99 P<n>``: to the caller's block N<n>); in the main
  program it starts the program again;
* ``G65 P<n> L<k> A.. Z..`` calls program O<n> as a macro: a new level of local variables,
  #1..#26 set from the arguments (argument specification I);
* a program is an ``O<n>`` section of a loaded file (:func:`ncsim.nc.iso.split_programs`) or a
  file ``O<n>``, ``O<nnnn>``, ``<n>`` with ``.MPF``, ``.SPF``, ``.NC``, ``.TXT`` or no extension
  in the caller's folder and the ``--subprograms`` folders; it is read in ISO mode.
"""
from __future__ import annotations

from ncsim.nc import program as P
from ncsim.nc.flow import Unit, compile_unit, split_units
from ncsim.nc.isomacro import level_refs, locals_of
from ncsim.nc.isoparse import ISO, IsoBlock, IsoProgramNumber, ModeSwitch
from ncsim.nc.parse import parse_text, read_program_text

#: G65 argument specification I: address -> local variable
_ARGUMENTS = {"A": 1, "B": 2, "C": 3, "I": 4, "J": 5, "K": 6, "D": 7, "E": 8, "F": 9, "H": 11,
              "M": 13, "Q": 17, "R": 18, "S": 19, "T": 20, "U": 21, "V": 22, "W": 23, "X": 24,
              "Y": 25, "Z": 26}
_FILE_EXTENSIONS = (".NC", ".TXT", ".ISO", ".EIA", "")


def split_programs(units: list[Unit]) -> list[Unit]:
    """An ISO file may hold several programs, each from its ``O<n>`` line: the first is the
    file's own unit, each later one a unit named ``O<n>`` (what M98 P<n> calls)."""
    out = []
    for unit in units:
        cut = [k for k, item in enumerate(unit.items) if isinstance(item, IsoBlock) and
               isinstance(item.statement, IsoProgramNumber) and
               any(_content(i) for i in unit.items[:k])]
        if not cut:
            out.append(unit)
            continue
        bounds = [0, *cut, len(unit.items)]
        for k, (a, b) in enumerate(zip(bounds, bounds[1:])):
            items = unit.items[a:b]
            name = unit.name if k == 0 else f"O{items[0].statement.number}"
            out.append(compile_unit(Unit(name, unit.file, items, unit.params,
                                         attributes=unit.attributes)))
    return out


def _content(item) -> bool:
    if isinstance(item, P.PlainRun):
        return True
    return bool(item.items) or (item.statement is not None and
                                not isinstance(item.statement, (IsoProgramNumber, ModeSwitch)))


class IsoCalls:
    """M98/M99/G65 for the ISO executor (:class:`ncsim.nc.iso.IsoExec`)."""

    def __init__(self, iso) -> None:
        self.iso = iso
        self.state = iso.state

    # ---- subprograms ---------------------------------------------------------------------------

    def m_call(self, ctx, code: int, col: int, extra: dict, used: set) -> None:
        state = self.state
        if code == 99:
            used.add("P")
            self._return(ctx, extra.get("P"))
            return
        used.update(("P", "L"))
        if "P" not in extra:
            raise ctx.error("M98 needs the program number P", col)
        number = ctx.whole_number(extra["P"][0], "P", extra["P"][1])
        repeats = 1
        if "L" in extra:
            repeats = ctx.whole_number(extra["L"][0], "L", extra["L"][1])
        elif number > 9999:
            repeats, number = number // 10000, number % 10000
        if repeats == 0:
            return
        unit = self._unit(ctx, number, col)
        self.iso.interp.calls.push(unit, (), repeats, level_refs(locals_of(state.stack)))

    def macro_call(self, ctx, col: int, words: list) -> None:
        """G65 P<n> L<k> A.. Z..: a new macro level whose #1..#26 are the arguments (argument
        specification I); the block holds nothing else."""
        given: dict = {}
        for address, value, wcol, _ in words:
            if address == "G":
                continue
            if address in given:
                raise ctx.error(f"{address} programmed twice in one block", wcol)
            if address not in _ARGUMENTS and address not in ("P", "L"):
                raise ctx.error(f"{address} is no G65 argument (A..Z without G L N O P)", wcol)
            given[address] = (value, wcol)
        if "P" not in given:
            raise ctx.error("G65 needs the program number P", col)
        number = ctx.whole_number(given["P"][0], "P", given["P"][1])
        repeats = 1 if "L" not in given else ctx.whole_number(given["L"][0], "L", given["L"][1])
        variables = {f"#{_ARGUMENTS[a]}": ["REAL", v] for a, (v, _) in given.items()
                     if a in _ARGUMENTS}
        unit = self._unit(ctx, number, col)
        if repeats:
            self.iso.interp.calls.push(unit, (), repeats, level_refs(variables))

    def _return(self, ctx, target) -> None:
        """M99: back to the caller (``P``: to its block N<p>); in the main program, to its start."""
        state = self.state
        fr = ctx.frame
        if len(state.stack) == 1:
            dest = (1 if fr.unit.items and _is_proc(fr.unit) else 0, 0)
            if target is not None:
                dest = find_number(fr.unit.items, int(target[0]), -1)
            if dest is None:
                raise ctx.error(f"M99 P: block N{int(target[0])} not found", target[1])
            state.jumped_back(ctx.file, ctx.line, ctx.first_col)
            fr.pc, fr.row = dest
            return
        self.iso.interp.calls.return_()
        caller = state.stack[-1]
        if target is not None and caller is not fr:
            dest = find_number(caller.unit.items, int(target[0]), caller.pc - 1)
            if dest is None:
                raise ctx.error(f"M99 P: block N{int(target[0])} not found in the caller",
                                target[1])
            caller.pc, caller.row = dest

    def _unit(self, ctx, number: int, col: int) -> Unit:
        """Program O<number>: a section of a loaded file, else a file."""
        name = f"O{number}"
        state = self.state
        unit = state.units.get(name)
        if unit is not None:
            return unit
        calls = self.iso.interp.calls
        first = calls.file_dirs.get(ctx.file) or state.search_dir
        path = None
        for candidate in (name, f"O{number:04d}", str(number), f"{number:04d}"):
            path = calls.finder.find(candidate, first, _FILE_EXTENSIONS)
            if path is not None:
                break
        if path is None:
            folders = ", ".join(calls.finder.searched(first)) or "no folder (a program given " \
                                                                 "as text)"
            raise ctx.error(f"program O{number} not found: no O{number} in the loaded programs "
                            f"and no file O{number} or {number} (.MPF, .SPF, .NC, .TXT) in "
                            f"{folders}", col)
        program = parse_text(read_program_text(path), str(path), fast=state.fast, dialect=ISO,
                             iso_plain=not self.iso.spec.standard_notation)
        calls.file_dirs[str(path)] = path.parent
        state.add_lines(program.n_lines)
        units = split_programs(split_units(program, name, subprogram=True))
        calls.add_units([u for u in units[1:] if u.name not in state.units])
        state.units.setdefault(name, units[0])
        return units[0]


def _is_proc(unit: Unit) -> bool:
    first = unit.items[0]
    return isinstance(first, P.Block) and isinstance(first.statement, P.Proc)


def find_number(items: list, number: int, here: int):
    """(index, row) of block N<number>: searched forward from after ``here``, then from the
    start (ISO Milling, "Macro programs", GOTO)."""
    order = list(range(here + 1, len(items))) + list(range(0, here + 1))
    for idx in order:
        item = items[idx]
        if isinstance(item, P.PlainRun):
            hits = (item.numbers == number).nonzero()[0]
            if len(hits):
                return idx, int(hits[0])
        elif item.number == number:
            return idx, 0
    return None
