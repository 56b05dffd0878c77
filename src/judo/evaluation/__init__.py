"""Speed and closed-loop quality as reproducible figures: `python -m judo benchmark` and `python -m
judo evaluate`.

timing.py times the control update against the raw rollout floor; episode.py runs seeded closed-loop
episodes with optional latency; stats.py summarises them; report.py is evaluate's table and JSON
record of them; plot.py draws an episode; benchmark.py and evaluate.py are the two commands.
"""
