"""physid.simulate (see docs/architecture.md)."""
