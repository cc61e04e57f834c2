"""A plant's masters together: the inventory (plant.toml), backing every master up into a
git archive, verifying them against it, and their state in one line each (docs/fleet.md)."""
