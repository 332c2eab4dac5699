"""Placeholder replaced by the ground-motion work (issue 3)."""
