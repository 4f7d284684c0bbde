"""Validation of error predictions against rendered images (issue 4: range error)."""
