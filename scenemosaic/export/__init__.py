"""export sub-package."""
