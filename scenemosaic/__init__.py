"""scenemosaic: simulation-ready indoor scenes and diverse layout variants from one reference scene."""
__version__ = "0.1.0"
