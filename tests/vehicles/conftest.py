"""The tests' own MAVLink peers (pymavlink's ``mavutil``, which the project does not use)
speak MAVLink 2: ``mavutil`` reads ``MAVLINK20`` when it is first imported, so it is set
before any test module here imports it."""

from __future__ import annotations

import os

os.environ.setdefault("MAVLINK20", "1")
