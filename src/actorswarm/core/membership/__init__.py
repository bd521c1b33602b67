"""Membership (docs/design.md §3.1): who is in this platform's view of the swarm.

:mod:`.view` is the view and its join and leave rules, :mod:`.detectors` decides when a
silence means gone, :mod:`.roster` is the star master's roster and the members' copy of it,
:mod:`.airtime` what a shared radio channel allows the heartbeats.
"""
