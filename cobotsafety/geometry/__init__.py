"""Pure, batched geometry: capsules and their distances."""
