"""What every command shares at its boundary: checks on its arguments, and Ctrl-C held off around
work that must not be cut in half."""
