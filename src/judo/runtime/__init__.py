"""The app: asyncio loops for the system, controller and GUI; the CLI."""
