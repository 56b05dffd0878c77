"""System identification: fit a planning model's parameters to logs of a plant (docs/sysid.md).

    excite.py       `python -m judo excite`: drive a plant with a band-limited excitation and log it
    drive.py        how excite serves its controls to a System, logs what it reports and halts it
    data.py         the logs a fit reads (HDF5, MCAP): their episodes
    windows.py      the K-step windows cut from the episodes and a model's prediction error over them
    parameters.py   the parameters a fit names (--params) and their values set in a model
    fit.py          the fit itself, with MuJoCo's `mujoco.sysid`
    hooks.py        mujoco.sysid's hooks: the windows as its sequences, the residual, the rollouts
    quality.py      how much of a log the fit explains, and which parameters would explain the rest
    sysid.py        `python -m judo sysid`: the command line and the report
    fitted_toml.py  the --config file a fit writes: the run's own, with the fitted parameters

This package sits above collection: it reads and writes collect's HDF5 layout. Nothing here is
imported by `import judo`; mujoco[sysid] (the `sysid` extra), h5py and the MCAP reader only where a
command needs them.
"""  # noqa: E501
