"""assets sub-package."""
