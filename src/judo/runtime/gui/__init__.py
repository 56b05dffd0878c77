"""The browser GUI (viser): scene, config panels generated from the dataclasses, controls and plots."""

from judo.runtime.gui.gui import Gui

__all__ = ["Gui"]
