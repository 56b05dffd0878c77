"""Policies in planning: a policy as the controller, as the proposal of some candidates, and read
from ONNX."""
