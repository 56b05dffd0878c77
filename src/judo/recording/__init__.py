"""Recordings in collect's HDF5 layout (docs/collect.md): the one room that writes and reads them.

    dataset.py     the file layout: DatasetFile writes episodes as data/demo_<seed>, and the readers' checks
    recorder.py    EpisodeRecorder: a Recorder (`judo.loop.records`) that gathers one episode into arrays
    live.py        recording a running app: what such a recorder does (LiveRecorder, RecorderFactory) and the
                   default one, LiveRecording, which writes the next demo of a file
    model_info.py  the configs and model hashes stored beside each recording

collect (judo.collection), the app's recording (judo.runtime.live_recording), replay, sysid and
distill all use it. h5py (the `collect` extra) is imported only when a file is opened.
"""  # noqa: E501
