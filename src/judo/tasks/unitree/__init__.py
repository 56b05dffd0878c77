"""Tasks for Unitree's robots: the Go2 standing and walking, the G1 standing, and the pushes both
take."""
