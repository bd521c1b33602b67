"""Reliable delivery (docs/design.md §3.3) over an unreliable radio.

:mod:`.reliable` is the per-destination streams (windows, retransmission, deduplication,
order, deadlines), :mod:`.rtt` their retransmission-time estimator, :mod:`.bulletin` one
message from the master to every member as one broadcast.
"""
