"""The options reference (``docs/options.md``), generated from the method registry.

Every method of :data:`scanmesh.methods.TABLE` with its one-line doc, and every option of it
with its kind, default, accepted range, doc and the flag of ``scanmesh reconstruct`` (read
from the command's own parser, so the page says what the command accepts)::

    python -m scanmesh.cli.reference > docs/options.md

Reads only ``TABLE``, each method's ``name``, ``doc`` and ``options``, merge's option table
(:data:`scanmesh.fusion.grid.OPTIONS`) and the ``Option`` fields, so the page follows the
registry wherever the rest of it moves.
"""

from __future__ import annotations

import argparse
import math
from typing import Any

from scanmesh.cli import build_parser
from scanmesh.fusion.grid import OPTIONS as MERGE_OPTIONS
from scanmesh.methods import TABLE

#: The page's opening: what it is and how it is made.
HEADER = """\
# Options reference

Every method of `scanmesh.reconstruct` and `scanmesh reconstruct` with its options: the
keyword, the command's flag, the kind, the default, the accepted range and what it does.
Generated from the method registry (`scanmesh.methods.TABLE`) by
`python -m scanmesh.cli.reference > docs/options.md`; do not edit it by hand (a test fails
when it is not current). A value out of range or of the wrong kind is refused with a
`ParameterError` naming the option, whichever way it came in.

Keywords every method shares (`plane`, and where a method uses them `lines`, `max_edge`,
`seed`, `progress`) and what the methods are for: [the user guide](guide/methods.md).
"""


def _number(value: float) -> str:
    """A number as Python reads it back (``inf``, ``1e-10``, ``5``), whole numbers grouped."""
    if isinstance(value, float) and math.isinf(value):
        return "inf" if value > 0 else "-inf"
    if isinstance(value, float):
        return f"{value:g}"
    return f"{value:,}"


def _default(option: Any) -> str:
    """The default as a reader types it."""
    value = option.default
    if value is None:
        return "`None`"
    if isinstance(value, bool):
        return f"`{value}`"
    if isinstance(value, (int, float)):
        return f"`{_number(value)}`"
    if isinstance(value, dict):
        return "`{" + ", ".join(f"{k}: {_number(v)}" for k, v in value.items()) + "}`"
    return f"`{value!r}`" if not isinstance(value, str) else f'`"{value}"`'


def _range(option: Any) -> str:
    """The values ``option.check`` accepts, as an interval or a list."""
    if option.kind == "bool":
        return "`True`, `False`"
    if option.choices:
        return ", ".join(
            f'`"{c}"`' if isinstance(c, str) else f"`{_number(c)}`" for c in option.choices
        )
    if option.kind not in ("int", "float"):
        return "see the description"
    low = "−∞" if option.low is None else _number(option.low)
    high = "∞" if option.high is None else _number(option.high)
    if option.kind == "int":
        text = f"{low} … {high}, whole"
    else:
        left = "(" if option.low is None or option.low_open else "["
        top_open = option.high is None or option.high_open
        right = ")" if top_open and (option.high is not None or option.finite) else "]"
        text = f"{left}{low}, {high}{right}"
    if option.automatic:
        text += "; `None`"
    return text


def _flags(parser: argparse.ArgumentParser, command: str) -> dict[str, argparse.Action]:
    """The actions of ``scanmesh COMMAND`` by option string."""
    sub = next(a for a in parser._actions if isinstance(a, argparse._SubParsersAction))
    return dict(sub.choices[command]._option_string_actions)


def _flag(option: Any, actions: dict[str, argparse.Action]) -> str:
    if option.flag not in actions:
        return "API only"
    action = actions[option.flag]
    if isinstance(action, argparse.BooleanOptionalAction):
        return f"`{option.flag}`, `--no-{option.flag[2:]}`"
    if action.choices:
        return f"`{option.flag} {{{','.join(map(str, action.choices))}}}`"
    return f"`{option.flag} {action.metavar or 'X'}`"


def _cell(text: str) -> str:
    return text.replace("|", "\\|").replace("\n", " ")


def _options_table(options: tuple[Any, ...], actions: dict[str, argparse.Action]) -> list[str]:
    """The lines of one table of options."""
    lines = ["| option | flag | kind | default | range | what |", "|---|---|---|---|---|---|"]
    for option in options:
        lines.append(
            f"| `{option.name}` | {_flag(option, actions)} | {option.kind}"
            f" | {_default(option)} | {_range(option)} | {_cell(option.doc)} |"
        )
    return lines


def reference() -> str:
    """The whole page, Markdown."""
    actions = _flags(build_parser(), "reconstruct")
    lines = [HEADER, "## Methods", "", "| method | what it does | options |", "|---|---|---|"]
    for method in TABLE.values():
        names = ", ".join(f"`{o.name}`" for o in method.options) or "none"
        lines.append(f"| [`{method.name}`](#{method.name}) | {_cell(method.doc)} | {names} |")
    for method in TABLE.values():
        lines += ["", f"## {method.name}", "", f"{method.doc[0].upper()}{method.doc[1:]}.", ""]
        if method.options:
            lines += _options_table(method.options, actions)
        else:
            lines.append("No options of its own.")
    lines += [
        "",
        "## merge",
        "",
        "Options of `scanmesh.merge` and `scanmesh merge` (besides the views, their poses and"
        " `toward`): the fusion grid. The guide: [merge](guide/merge.md).",
        "",
    ]
    lines += _options_table(MERGE_OPTIONS, _flags(build_parser(), "merge"))
    return "\n".join(lines) + "\n"


if __name__ == "__main__":
    print(reference(), end="")
