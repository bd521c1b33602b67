"""Plugins that ship with actorswarm beyond the two core ones of
:mod:`actorswarm.runtime.builtin`, registered as ``actorswarm.plugins`` entry points.

:mod:`actorswarm.plugins.flight`
    ``flight.takeoff``, ``flight.goto`` and ``flight.return_home``: the vehicle plugins of
    the paper's Standby, Ingress and Return actors.
"""
