"""The browser GUI (viser): scene, config panels generated from the dataclasses, controls and plots.

The app builds it from judo.runtime.gui.gui.Gui.
"""
