"""physid.report (see docs/architecture.md)."""
