"""Built-in optimizers, one algorithm per file with its config; judo.builtin registers them by
name."""
