"""The command line (`rhythmjax`): verbs, overlays and figures. Nothing in the library imports
this package."""

from .main import main as main


__all__ = ["main"]
