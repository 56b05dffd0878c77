"""Switching task and optimizer again and again does not grow the GUI server's state."""

from judo.runtime.app import App


def test_switches_leave_no_removed_widgets_in_the_servers_replay_buffer(port, wait_until):
    app = App("cartpole", "ps", port=port, seed=0, num_workers=1)
    app.start()
    try:
        buffer = app.gui.server._websock_server._broadcast_buffer.message_from_id

        def switch(optimizer: str) -> None:
            app.commands.switch_optimizer(optimizer)
            wait_until(
                lambda: (
                    app.session.optimizer_name == optimizer
                    and app.gui.shown_generation == app.session.generation
                ),
                what=f"the GUI to show {optimizer}",
            )

        for optimizer in ("cem", "ps"):
            switch(optimizer)
        settled = len(buffer)
        for _ in range(6):
            for optimizer in ("cem", "ps"):
                switch(optimizer)
        assert len(buffer) <= settled + 10  # before the purge: about 19 more messages per switch
    finally:
        app.stop()
