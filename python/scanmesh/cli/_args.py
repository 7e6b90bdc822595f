"""Argument types and the flags shared by subcommands: the reader flags, the method
options (one flag per option of the methods table) and the colouring flags."""

from __future__ import annotations

import argparse
import math
from collections.abc import Callable, Sequence
from typing import Any

from scanmesh._checks import POSITIVE
from scanmesh._context import seed_of
from scanmesh.errors import ParameterError
from scanmesh.methods import (
    DEFAULT_METHOD,
    FALLBACK_METHOD,
    INITIALS,
    SHARED,
    TABLE,
    used_keywords,
)
from scanmesh.present.render import COLOR_BY


def _plane(text: str) -> str | tuple[float, float, float]:
    """--plane: best-fit, x, y, z or a normal vector "nx,ny,nz"."""
    name = text.strip().lower()
    if name in ("best-fit", "x", "y", "z"):
        return name
    parts = _vector(name)
    if parts is None:
        raise argparse.ArgumentTypeError(
            f"{text!r} is not best-fit, x, y, z or a non-zero vector like 0,0,1"
        )
    return parts


def _vector(text: str) -> tuple[float, float, float] | None:
    """A finite non-zero 3-vector written "x,y,z" (or space separated), else None."""
    try:
        parts = tuple(float(t) for t in text.replace(" ", ",").split(",") if t)
    except ValueError:
        return None
    if len(parts) != 3 or not all(map(math.isfinite, parts)) or not any(parts):
        return None
    return parts  # type: ignore[return-value]


def _axis(text: str) -> str | tuple[float, float, float]:
    """--up, --along, --view: an axis name (x, -y, +z) or a vector "x,y,z"."""
    name = text.strip().lower()
    if name.lstrip("+-") in ("x", "y", "z") and len(name) <= 2:
        return name
    parts = _vector(name)
    if parts is None:
        raise argparse.ArgumentTypeError(
            f"{text!r} is not an axis (x, -y, +z, ...) or a non-zero vector like 0,0,1"
        )
    return parts


def _positive(text: str) -> float:
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r} is not a number") from None
    try:
        return POSITIVE.check(value)  # the one positive-number check
    except ParameterError:
        raise argparse.ArgumentTypeError(f"{text!r} is not a positive number") from None


def _max_edge(text: str) -> float:
    if text.strip().lower() in ("inf", "infinity", "none"):
        return math.inf
    return _positive(text)


def _non_negative(text: str) -> float:
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r} is not a number") from None
    if not (value >= 0) or not math.isfinite(value):
        raise argparse.ArgumentTypeError(f"{text!r} is not a number >= 0")
    return value


def _holdout_fraction(text: str) -> float:
    """--holdout: a share in [0, 1)."""
    value = _non_negative(text)
    if value >= 1:
        raise argparse.ArgumentTypeError(f"{text!r} is not a share below 1")
    return value


def _count(text: str) -> int:
    try:
        value = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r} is not a whole number") from None
    if value < 0:
        raise argparse.ArgumentTypeError(f"{text!r} is negative")
    return value


def _positive_count(text: str) -> int:
    value = _count(text)
    if value == 0:
        raise argparse.ArgumentTypeError(f"{text!r} is not positive")
    return value


def _size(text: str) -> tuple[int, int]:
    try:
        w, h = (int(t) for t in text.lower().split("x"))
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r} is not a size like 800x600") from None
    if not (16 <= w <= 8000 and 16 <= h <= 8000):
        raise argparse.ArgumentTypeError(f"{text!r}: width and height must be 16..8000")
    return w, h


def _add_read_flags(p: argparse.ArgumentParser) -> None:
    """Flags that choose what is read from a scan file (see scanmesh.formats)."""
    p = p.add_argument_group("reading the scan file")  # type: ignore[assignment]
    p.add_argument(
        "--columns",
        metavar="COLS",
        help="columns of x, y, z (and line) in file"
        " order, e.g. x,y,z,intensity,line, or their indices, e.g. 0,1,2,4",
    )
    p.add_argument(
        "--decimal",
        choices=(".", ","),
        help="XYZ/CSV: the decimal mark; ',' reads 1,5 as 1.5 (values then separated by"
        " semicolons, tabs or spaces)",
    )
    p.add_argument(
        "--returns",
        metavar="WHICH",
        help="LAS/LAZ: first (default), last, all or return numbers, e.g. 1,2",
    )
    p.add_argument("--classes", metavar="C", help="LAS/LAZ: ASPRS classes to keep, e.g. 2")
    p.add_argument(
        "--grid",
        action="store_true",
        help="read a matrix of heights (text, CSV, .npy), each row a scan line",
    )
    p.add_argument("--cell", type=float, metavar="SIZE", help="cell size of a height grid")


#: The reader flags (their keywords of read(): --columns is columns=).
READ_FLAGS: tuple[str, ...] = ("columns", "decimal", "returns", "classes", "grid", "cell")


def _read_options(args: argparse.Namespace | None) -> dict[str, Any]:
    """The reader flags given (:data:`READ_FLAGS`), as keywords of read()."""
    return {k: getattr(args, k) for k in READ_FLAGS if getattr(args, k, None) not in (None, False)}


def _method_flags() -> dict[str, tuple[Any, list[str]]]:
    """Every method option the command takes, by name: (the Option, the methods using it).

    Options without a textual form (a weight mapping, an incumbent triangulation) stay
    API-only; ``initial`` is offered by name."""
    flags: dict[str, tuple[Any, list[str]]] = {}
    for spec in TABLE.values():
        for option in spec.options:
            if option.kind == "any" and option.name != "initial":
                continue
            flags.setdefault(option.name, (option, []))[1].append(spec.name)
    return flags


def _flag_text(kind: str) -> Callable[[str], Any]:
    """argparse type of a flag: the text as a number (range checks come from the table)."""

    def convert(text: str) -> Any:
        try:
            return int(text) if kind == "int" else float(text)
        except ValueError:
            what = "a whole number" if kind == "int" else "a number"
            raise argparse.ArgumentTypeError(f"{text!r} is not {what}") from None

    return convert


#: Options whose None means "no limit" rather than "worked out from the data".
UNLIMITED_BY_NONE = frozenset({"time_limit"})


def _default_text(option: Any) -> str:
    """An option's default as its help shows it."""
    if option.default is None:
        return "no limit" if option.name in UNLIMITED_BY_NONE else "automatic"
    return f"{option.default:g}" if isinstance(option.default, float) else str(option.default)


def _flag_help(name: str, users: list[str]) -> str:
    """Help of the flag of option ``name``: its doc and default, per method where the
    methods using it differ in either (e.g. --time-limit of annealing and of optimal)."""

    texts: dict[tuple[str, str], list[str]] = {}
    for user in users:
        option = next(o for o in TABLE[user].options if o.name == name)
        texts.setdefault((option.doc, _default_text(option)), []).append(user)
    return "; ".join(
        f"{doc} ({', '.join(methods)}; default {shown})" for (doc, shown), methods in texts.items()
    )


def _add_method_flags(parser: argparse.ArgumentParser) -> None:
    """One flag per method option of the table, listed in the help under the first method
    that takes it (its help names every method that does)."""
    groups: dict[str, Any] = {}
    for option, users in _method_flags().values():
        if users[0] not in groups:
            groups[users[0]] = parser.add_argument_group(
                f"options of --method {users[0]} (and of the methods each names)"
            )
        add_option_flag(groups[users[0]], option, _flag_help(option.name, users))


def add_option_flag(group: Any, option: Any, text: str) -> None:
    """The flag of ``option`` (a ``_checks.Option``) with help ``text``: a switch for a
    bool, the choices for a choice, else a number whose range the table checks (default
    None: not given)."""
    text = text.replace("%", "%%")
    if option.kind == "bool":
        group.add_argument(
            option.flag, action=argparse.BooleanOptionalAction, default=None, help=text
        )
    elif option.name == "initial":
        group.add_argument(option.flag, choices=INITIALS, default=None, help=text)
    elif option.kind == "choice":
        group.add_argument(option.flag, choices=option.choices, default=None, help=text)
    else:
        group.add_argument(
            option.flag,
            type=_flag_text(option.kind),
            default=None,
            metavar="N" if option.kind == "int" else "X",
            help=text,
        )


def option_help(option: Any) -> str:
    """``doc (default D)`` of an option with a single user (merge's)."""
    return f"{option.doc} (default {_default_text(option)})"


def _given_flags(args: argparse.Namespace) -> dict[str, Any]:
    """The method flags on the command line (name -> value)."""
    return {
        name: getattr(args, name)
        for name in _method_flags()
        if getattr(args, name, None) is not None
    }


def chosen_method(args: argparse.Namespace, dask: bool = False) -> str:
    """``--method`` as given; without it the fallback (annealing) when only its flags are
    given (they meant annealing when it was the default) or on Dask (which has no "auto"),
    else the default method (both: :mod:`scanmesh.methods`)."""
    if args.method is not None:
        return str(args.method)
    flags = _method_flags()
    given = _given_flags(args)
    if dask or (given and all(FALLBACK_METHOD in flags[name][1] for name in given)):
        return FALLBACK_METHOD
    return DEFAULT_METHOD


def _refuse_stray_flags(
    args: argparse.Namespace, methods: Sequence[str], seeded: bool = False
) -> None:
    """A usage error for a flag none of ``methods`` uses (nothing is silently dropped);
    ``seeded``: the command itself uses --seed (compare's error sampling and holdout)."""
    flags = _method_flags()
    for name in _given_flags(args):
        option, users = flags[name]
        if not set(users) & set(methods):
            args._parser.error(f"{option.flag} applies to --method {', '.join(users)} only")
    for name in ("max_edge",) if seeded else ("max_edge", "seed"):
        if getattr(args, name, None) is not None and not any(
            name in TABLE[m].shared for m in methods
        ):
            users = [m for m, spec in TABLE.items() if name in spec.shared]
            flag = "--" + name.replace("_", "-")
            args._parser.error(f"{flag} applies to --method {', '.join(users)} only")


def _method_options(args: argparse.Namespace, method: str) -> dict[str, Any]:
    """The method flags ``method`` uses, checked by the table with the flag's name."""
    options = {o.name: o for o in TABLE[method].options}
    return {
        name: options[name].check(value, options[name].flag)
        for name, value in _given_flags(args).items()
        if name in options
    }


def _shared(args: argparse.Namespace, method: str, options: dict[str, Any]) -> dict[str, Any]:
    """--max-edge and --seed for a method that uses them (seed 0 when not given)."""
    used = used_keywords(method, options)
    shared: dict[str, Any] = {}
    if "max_edge" in used and args.max_edge is not None:
        shared["max_edge"] = SHARED["max_edge"].check(args.max_edge, "--max-edge")
    if "seed" in used:
        given = None if args.seed is None else SHARED["seed"].check(args.seed, "--seed")
        shared["seed"] = seed_of(given)
    return shared


def _color_flags(p: argparse.ArgumentParser) -> None:
    p.add_argument(
        "--color",
        choices=COLOR_BY,
        default=None,
        help="colour faces by tac, by error (distance to --truth) or by height (along --up"
        " or the surface's normal); default one colour",
    )
    p.add_argument("--truth", metavar="PART", help="true surface (mesh file) for --color error")
