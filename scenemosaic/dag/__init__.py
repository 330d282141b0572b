"""dag sub-package."""
