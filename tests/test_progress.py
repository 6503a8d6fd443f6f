"""Progress of a DEM run: a bar on a terminal, periodic log lines otherwise."""

import fcntl
import os
import pty
import select
import struct
import subprocess
import sys
import termios

SCRIPT = """
import logging, sys
sys.path.insert(0, "tests")
logging.basicConfig(level=logging.INFO)
from helpers import floor_system, run
from ballmill.dem import Material
spec = floor_system(Material("steel", 7900.0, 77e7, 0.3), 0.01, [[0.0, 0.0, -0.5]], gravity=(0, 0, -9.81))
run(spec, 1e-5, 0.05, sample_every=1e-3, phases=((0.0, "falling"), (0.02, "resting")))
"""


def run_with_stderr(tty: bool) -> str:
    root = os.path.dirname(os.path.dirname(__file__))
    if not tty:
        return subprocess.run([sys.executable, "-c", SCRIPT], cwd=root, capture_output=True, text=True,
                              check=True).stderr
    leader, follower = pty.openpty()
    fcntl.ioctl(follower, termios.TIOCSWINSZ, struct.pack("HHHH", 24, 160, 0, 0))  # a 160-column terminal
    proc = subprocess.Popen([sys.executable, "-c", SCRIPT], cwd=root, stdout=subprocess.DEVNULL, stderr=follower)
    chunks = []
    while True:
        ready, _, _ = select.select([leader], [], [], 0.1)
        if ready:
            chunks.append(os.read(leader, 65536))
        elif proc.poll() is not None:
            break
    os.close(follower)
    os.close(leader)
    assert proc.returncode == 0
    return b"".join(chunks).decode(errors="replace")


def test_a_terminal_gets_a_progress_bar_with_phase_and_rate():
    out = run_with_stderr(tty=True)
    assert "\r" in out  # a bar redrawn in place
    assert "resting" in out and "particle-steps/s" in out and "sample" in out


def test_without_a_terminal_progress_is_log_lines_only():
    err = run_with_stderr(tty=False)
    assert "\r" not in err
    assert "run: t=0.0500 s resting (50/50 samples)" in err
