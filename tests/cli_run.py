"""``synth ARGV`` run in this process for the CLI tests: exit status, stdout and stderr."""

import re

from synth.cli import main

#: The note a first use prints before compiling a kernel group (synth.compilation.announce):
#: it depends on numba's disk cache, not on the command, so the tests do not see it.
COMPILE_NOTE = re.compile(r"^synth: compiling .* for first use.*\n", re.M)


def run(capsys, *argv):
    """Exit status, stdout and stderr (without compile notes) of ``synth ARGV``."""
    code = main([str(a) for a in argv])
    out, err = capsys.readouterr()
    return code, out, COMPILE_NOTE.sub("", err)
