"""Rollout machinery: the backend interface and its CPU and Warp backends, worker threads, batched
problems, low-level policies and numpy dynamics inside rollouts, randomized models and risk measures
over them."""
