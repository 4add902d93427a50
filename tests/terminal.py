"""Running shbake with stderr on a pseudo-terminal, and reading the progress bars it drew
(the tests of progress with real totals, issue 32: test_run_reports, test_preview_progress)."""

import fcntl
import os
import pty
import re
import select
import struct
import subprocess
import sys
import termios


def run_on_terminal(*args, cwd=None) -> tuple[int, str]:
    """``shbake ARGS`` with stderr on a 120-column pseudo-terminal (stdout a pipe); (status,
    what the terminal received). tqdm redraws on every step (``TQDM_MININTERVAL=0``)."""
    master, slave = pty.openpty()
    fcntl.ioctl(slave, termios.TIOCSWINSZ, struct.pack("HHHH", 40, 120, 0, 0))  # rows, columns
    env = dict(os.environ, TQDM_MININTERVAL="0")
    code = "import sys; from shbake_cli.main import main; sys.exit(main(sys.argv[1:]))"
    proc = subprocess.Popen([sys.executable, "-c", code, *map(str, args)], stdout=subprocess.PIPE,
                            stderr=slave, stdin=subprocess.DEVNULL, cwd=cwd, env=env)  # fmt: skip
    os.close(slave)
    received = bytearray()
    while True:
        ready, _, _ = select.select([master], [], [], 1.0)
        if ready:
            try:
                chunk = os.read(master, 65536)
            except OSError:  # EIO: the child closed the terminal
                break
            if not chunk:
                break
            received += chunk
        elif proc.poll() is not None:
            break
    os.close(master)
    proc.stdout.read()
    return proc.wait(), received.decode("utf-8", "replace")


def bar_counts(drawn: str, unit: str) -> tuple[set[int], set[int]]:
    """The ``n/total unit`` pairs tqdm drew: (the counts, the totals)."""
    found = re.findall(rf"(\d+)/(\d+) \[[^\]]*{unit}", drawn)
    return {int(n) for n, _ in found}, {int(t) for _, t in found}
