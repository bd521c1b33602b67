"""The launcher's output as the tests read it."""

from __future__ import annotations

import re
import subprocess
import threading
import time


class LauncherOutput:
    """The launcher's output, read as it comes."""

    def __init__(self, proc: subprocess.Popen[str]) -> None:
        self.lines: list[str] = []
        assert proc.stdout is not None
        stream = proc.stdout
        threading.Thread(target=lambda: self.lines.extend(stream), daemon=True).start()

    def wait_for(self, pattern: str, timeout: float = 30.0, count: int = 1) -> re.Match[str]:
        """The ``count``-th line matching ``pattern``, once there is one."""
        end = time.monotonic() + timeout
        while time.monotonic() < end:
            found = [m for line in list(self.lines) if (m := re.search(pattern, line))]
            if len(found) >= count:
                return found[count - 1]
            time.sleep(0.1)
        raise AssertionError(f"no {pattern!r} in the launcher's output:\n{''.join(self.lines)}")
