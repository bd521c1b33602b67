"""``actorswarm task verify``: a user's own mission tried under many seeded fault schedules.

The layers, each its own module: :mod:`.profile` (what can go wrong, and how often: a TOML
fault profile), :mod:`.schedule` (one run's faults drawn from it by a seed, as ``sim``
options), :mod:`.runner` (one run in the simulator, and what came of it), :mod:`.minimize`
(delta debugging: the fewest faults that still fail the same way), :mod:`.pool` (this
machine's cores or a Ray cluster), :mod:`.session` (the whole verify: run, group,
minimize), :mod:`.report` (terminal, JSON, HTML) and :mod:`.scenario` (the script's own
``<?actorswarm sim ...?>`` line).
"""
