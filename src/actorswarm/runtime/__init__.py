"""The actor runtime (DESIGN.md §5): Actor Control Blocks, the operations that move an actor
between its states, exclusive hardware resources, the OODA buses and the plugins they run."""
