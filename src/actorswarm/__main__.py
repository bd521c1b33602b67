"""``python -m actorswarm`` runs the command line."""

from actorswarm.cli.app import main

if __name__ == "__main__":
    main()
