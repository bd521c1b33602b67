"""The simulated swarm: a discrete-event scheduler in virtual time and a simulated radio.

Everything here is deterministic: time is virtual (no wall clock is ever read) and every
random choice comes from a ``random.Random`` the caller seeds, so one seed gives one run.
"""
