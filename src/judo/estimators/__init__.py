"""Built-in estimators, one per file with its config; judo.builtin registers them by name."""
