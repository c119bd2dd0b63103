"""physid.analysis (see docs/architecture.md)."""
