"""Documentation generated from the code, so it cannot drift: each module renders one block
of a document between markers and can print, write or check it (``python -m
actorswarm.docgen.<module> --check``); the tests fail when a block is stale.

Nothing in the layers imports this package: it reads them, they never read it.
"""
