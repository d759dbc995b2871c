"""The command line: ``synth SUBCOMMAND ...`` (argparse; docs/cli.md): the parser and
:func:`main` (exit statuses, SIGTERM, warnings as one line; an input error is one line on
stderr, status 2); the subcommands live in the modules of their areas.
"""

from __future__ import annotations

import argparse
import contextlib
import sys

from synth.cli.bank import add_bank_gain_parser, add_bank_parser
from synth.cli.bench import add_bench_parser, add_warmup_parser, bench_arguments
from synth.cli.catalog import add_cache_parser, add_materials_parser, add_presets_parser
from synth.cli.play import add_play_parser
from synth.cli.recordings import add_alter_parser, add_analyze_parser
from synth.cli.render import add_gallery_parser, add_info_parser, add_render_parser
from synth.errors import SynthError
from synth.store.atomic import commits_refused_by, refuse_commits

#: Each subcommand's parser, in the order of ``synth --help``.
SUBCOMMANDS = (
    add_info_parser, add_render_parser, add_analyze_parser, add_alter_parser,
    add_gallery_parser, add_presets_parser, add_materials_parser, add_bank_parser,
    add_bank_gain_parser, add_cache_parser, add_play_parser, add_warmup_parser, add_bench_parser,
)  # fmt: skip


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="synth", description="Physically based bouncing and impact sounds."
    )
    sub = parser.add_subparsers(dest="command", required=True)
    for add in SUBCOMMANDS:
        add(sub)
    return parser


class Terminated(KeyboardInterrupt):
    """SIGTERM, raised in the main thread to unwind like Ctrl-C (temporaries removed)."""


def _on_sigterm(signum, frame):
    stop = Terminated()
    refuse_commits(stop)  # holds where the exception below is swallowed
    raise stop


@contextlib.contextmanager
def _silent_swallowed_terminations():
    """Keep Python from printing a :class:`Terminated` that a finalizer or weakref callback
    swallowed (``sys.unraisablehook``): SIGTERM's handler runs wherever the main thread is.
    The stop itself holds (:func:`synth.store.atomic.refuse_commits`)."""
    previous = sys.unraisablehook

    def hook(unraisable):
        if not isinstance(unraisable.exc_value, Terminated):
            previous(unraisable)

    sys.unraisablehook = hook
    try:
        yield
    finally:
        sys.unraisablehook = previous


def _show_warning(message, category, filename, lineno, file=None, line=None):
    """A warning as one line of the command's own, without the engine's source line."""
    print(f"synth: warning: {message}", file=sys.stderr if file is None else file)


def main(argv=None) -> int:
    import signal
    import threading
    import warnings

    argv = sys.argv[1:] if argv is None else list(argv)
    if argv[:1] == ["bench"]:  # the rest is the benchmarks' command line (synth.cli.bench)
        args = bench_arguments(argv[1:])
    else:
        args = build_parser().parse_args(argv)
    previous = None
    if threading.current_thread() is threading.main_thread():
        previous = signal.signal(signal.SIGTERM, _on_sigterm)
    try:
        with warnings.catch_warnings(), _silent_swallowed_terminations():
            warnings.showwarning = _show_warning
            status = args.func(args)
        stop = commits_refused_by()
        if stop is not None:  # a SIGTERM that some code swallowed
            raise stop
        return status
    except SynthError as exc:
        print(f"synth: error: {exc}", file=sys.stderr)
        return 2
    except BrokenPipeError:  # output piped into a program that stopped reading (head)
        import os

        os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())
        return 0
    except OSError as exc:  # the system refused: full disk, read-only folder, I/O error
        import errno

        where = f" ({exc.filename})" if exc.filename else ""
        if exc.errno == errno.EFBIG:
            where += " (this process' file size limit: ulimit -f)"
        print(f"synth: error: {exc.strerror or exc}{where}", file=sys.stderr)
        return 1
    except Terminated:
        print("synth: terminated (SIGTERM); nothing partial was left", file=sys.stderr)
        return 128 + signal.SIGTERM
    except KeyboardInterrupt:
        return 130
    finally:
        if previous is not None:
            signal.signal(signal.SIGTERM, previous)
        refuse_commits(None)
