"""physid.estimators (see docs/architecture.md)."""
