"""Command-line interface: ``bayestissue <command> ...``.

Each sub-command lives in its own module ``bayestissue/cli/<name>.py`` exposing ``register(subparsers)``,
which adds its parser and sets ``func(args) -> int``. This is the only layer that prints. Bad input
(``ValueError``, ``FileNotFoundError``) is reported as one line on stderr and exit status 2, never a traceback;
the output paths a command declares are checked before it runs. Any other ``OSError``, and a nested run whose
sampler stalled or met a likelihood plateau it cannot cross (``SamplerStalled``, ``LikelihoodPlateau``), is one line
and status 1.
"""

from __future__ import annotations

import argparse
import importlib
import logging
import math
import sys
import time
from pathlib import Path

from bayestissue import __version__

__all__ = ["main", "build_parser", "plain", "progress_bar", "run_lines", "seed", "stage_parser"]

#: Sub-command modules, in the order ``--help`` lists them.
_COMMANDS = ("simulate", "fit", "hierarchy", "importer", "stereology", "micrographs")


class _Parser(argparse.ArgumentParser):
    def error(self, message):  # argparse's own usage errors: exit 2 with a one-line message
        self.print_usage(sys.stderr)
        self.exit(2, f"{self.prog}: error: {message}\n")


def seed(text: str) -> int:
    """argparse type of every ``--seed``: an integer >= 0 (numpy's generators refuse a negative seed, naming no
    option)."""
    try:
        value = int(text)
    except ValueError:
        value = -1
    if value < 0:
        raise argparse.ArgumentTypeError(f"expected an integer >= 0, got {text!r}")
    return value


def plain(text: str) -> str:
    """A docstring's text for --help: without reStructuredText's double backquotes."""
    return text.replace("``", "")


def progress_bar(args, **kwargs):
    """A tqdm bar on stderr, off under the command's ``--quiet`` or the global ``bayestissue --quiet``."""
    from tqdm import tqdm

    return tqdm(file=sys.stderr, disable=bool(getattr(args, "quiet", False)), **kwargs)


def run_lines(label: str, seconds: float = 60.0):
    """A nested engine's ``progress`` callback for a long study stage or benchmark: prints ``{label} run {run}:
    {calls} calls, log Z so far {log_z}`` at most every ``seconds`` (a killed stage's log still says how far each run
    got); without the log Z where the engine does not report one during the run (UltraNest's population step passes
    NaN)."""
    last = [time.perf_counter()]

    def report(run, n_evaluations, n_eff, explored, log_z):
        if time.perf_counter() - last[0] >= seconds:
            last[0] = time.perf_counter()
            so_far = f", log Z so far {log_z:.3f}" if math.isfinite(log_z) else ""
            print(f"{label} run {run}: {n_evaluations} calls{so_far}", flush=True)

    return report


def stage_parser(doc: str, quick: str, full: str, out) -> argparse.ArgumentParser:
    """The parser a ``--full`` study stage starts from (studies/full_model.py, evidence_check.py,
    tendon_branches.py): ``--quick`` or ``--full`` (help texts ``quick``, ``full``; neither: read the committed
    record back) and ``--out`` (default ``out``); its description is ``doc``'s first line."""
    ap = argparse.ArgumentParser(description=doc.splitlines()[0])
    mode = ap.add_mutually_exclusive_group()
    mode.add_argument("--quick", action="store_true", help=quick)
    mode.add_argument("--full", action="store_true", help=full)
    ap.add_argument("--out", type=Path, default=out)
    return ap


def build_parser() -> argparse.ArgumentParser:
    parser = _Parser(
        prog="bayestissue",
        description="Bayesian calibration of soft-tissue models, stereology and micrographs; "
        "'bayestissue <command> --help' for each command.",
    )
    parser.add_argument("--version", action="version", version=f"%(prog)s {__version__}")
    parser.add_argument("-v", "--verbose", action="store_true", help="log progress at INFO level")
    parser.add_argument(
        "-q", "--quiet", dest="global_quiet", action="store_true",
        help="no progress bars in any command (before the command: bayestissue --quiet fit ...)",
    )  # fmt: skip
    sub = parser.add_subparsers(dest="command", required=True, parser_class=_Parser)
    for name in _COMMANDS:
        importlib.import_module(f"bayestissue.cli.{name}").register(sub)
    return parser


def _check_outputs(args) -> None:
    """The output paths a command declared (``set_defaults(outputs={label: (dest, "file" | "dir")})``), checked
    before it runs."""
    from bayestissue.io.paths import check_output_dir, check_output_file

    for label, (dest, kind) in getattr(args, "outputs", {}).items():
        value = getattr(args, dest, None)
        if value is not None:
            (check_output_file if kind == "file" else check_output_dir)(label, value)


def main(argv: list[str] | None = None) -> int:
    parser = build_parser()
    args = parser.parse_args(argv)
    level = logging.INFO if args.verbose else logging.WARNING
    logging.basicConfig(level=level, format="%(levelname)s %(message)s")
    for handler in logging.getLogger().handlers:  # libraries that set their loggers' levels (dask's INFO start-up
        handler.setLevel(level)  # chatter) print no more than the command asked for
    if args.global_quiet:  # every command's own switch
        args.no_progress = args.quiet = True
    try:
        _check_outputs(args)
        return int(args.func(args) or 0)
    except BrokenPipeError:  # output piped into e.g. `head`
        sys.stderr.close()
        return 0
    except KeyboardInterrupt:  # Ctrl-C: one line, and how to go on where a run checkpoints
        out = getattr(args, "out", None)
        hint = (f"; what was checkpointed in {out} is kept: the same command with --resume continues it"
                if hasattr(args, "resume") and out else "")  # fmt: skip
        print(f"bayestissue {args.command}: interrupted{hint}", file=sys.stderr)
        return 130
    except (ValueError, FileNotFoundError, KeyError) as exc:
        msg = exc.args[0] if isinstance(exc, KeyError) and exc.args else exc
        print(f"bayestissue {args.command}: error: {msg}", file=sys.stderr)
        return 2
    except RuntimeError as exc:  # a sampler that stopped making progress (the checkpoints are kept)
        from bayestissue.inference.sampling.ultranest_run import LikelihoodPlateau, SamplerStalled

        if not isinstance(exc, (SamplerStalled, LikelihoodPlateau)):
            raise
        out = getattr(args, "out", None)
        print(f"bayestissue {args.command}: error: {exc}" + (f"; what it checkpointed is in {out}" if out else ""),
              file=sys.stderr)  # fmt: skip
        return 1
    except OSError as exc:  # a path the checks could not foresee (disk full, permissions changed while running)
        where = f": {exc.filename}" if exc.filename else ""
        print(f"bayestissue {args.command}: error: {exc.strerror or exc}{where}", file=sys.stderr)
        return 1


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
