"""The ``cgbound`` command line: ``demo`` (the paper's Fig. 3) and ``run`` (any dataset).

Errors are one line, ``cgbound: error: --flag: what was expected, what was given``, with exit
status 2 for arguments and 1 for data; ``--debug`` shows the traceback instead.
"""
import argparse
import sys
import warnings

from . import demo, run
from .errors import UsageError

__all__ = ["main", "UsageError"]


class Parser(argparse.ArgumentParser):
    """argparse with one-line errors (``cgbound: error: ...``, exit status 2)."""

    def error(self, message):
        print(f"cgbound: error: {message} (see {self.prog} --help)", file=sys.stderr)
        raise SystemExit(2)


def build_parser():
    parser = Parser(prog="cgbound", description="Boundary-aware coarse graining of discrete-particle data.",
                    epilog="examples: cgbound demo --figure demo.png; cgbound run --help")
    sub = parser.add_subparsers(dest="command", required=True, parser_class=Parser)
    for command in (demo, run):
        p = command.add_parser(sub)
        p.add_argument("--debug", action="store_true", help="show the Python traceback of an error")
    return parser


def show_warning(message, category, filename, lineno, file=None, line=None):
    """Warnings as one line on stderr, like the errors."""
    print(f"cgbound: warning: {one_line(message)}", file=sys.stderr)


def main(argv=None):
    """Run the command line; returns the exit status."""
    args = build_parser().parse_args(argv)
    try:
        with warnings.catch_warnings():
            if not args.debug:
                warnings.showwarning = show_warning
            args.check(args)
            return args.func(args)
    except KeyboardInterrupt:
        if args.debug:
            raise
        print("cgbound: interrupted", file=sys.stderr)
        return 130
    except UsageError as exc:
        if args.debug:
            raise
        print(f"cgbound: error: {one_line(exc)}", file=sys.stderr)
        return 2
    except Exception as exc:  # data that cannot be read or coarse-grained: one line, no traceback
        if args.debug:
            raise
        print(f"cgbound: error: {one_line(exc)}", file=sys.stderr)
        return 1


def one_line(exc):
    text = " ".join(str(exc).split())
    return text or type(exc).__name__
