"""``python -m actorswarm`` runs the command line."""

from actorswarm.cli import main

if __name__ == "__main__":
    main()
