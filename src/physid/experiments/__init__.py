"""physid.experiments (see docs/architecture.md)."""
