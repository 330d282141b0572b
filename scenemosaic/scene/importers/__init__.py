"""Importers behind load_scene."""
