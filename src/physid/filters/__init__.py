"""physid.filters (see docs/architecture.md)."""
