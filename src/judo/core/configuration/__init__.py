"""Configuration: the config base class and its fields, TOML files, `kind.field` names, model
overrides, and the name -> class registries of tasks, optimizers and estimators."""
