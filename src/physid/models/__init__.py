"""physid.models (see docs/architecture.md)."""
