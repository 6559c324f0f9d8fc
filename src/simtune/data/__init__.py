"""Recordings (motion capture, joint logs): loading, writing, and per-task reference data.

Formats are described in docs/recordings.md.
"""

from simtune.data.csvformat import write_csv
from simtune.data.fingerprint import data_fingerprint, fingerprint_changes, task_files
from simtune.data.loaders import RECORDING_SUFFIXES, load_recording
from simtune.data.qualisys import write_qualisys_tsv
from simtune.data.recording import QRG2019_BODIES, Recording
from simtune.data.rosbag import read_joint_bag, write_joint_bag
from simtune.data.task import TaskData, load_task_data, resample

__all__ = [
    "QRG2019_BODIES",
    "RECORDING_SUFFIXES",
    "Recording",
    "TaskData",
    "data_fingerprint",
    "fingerprint_changes",
    "load_recording",
    "load_task_data",
    "read_joint_bag",
    "resample",
    "task_files",
    "write_csv",
    "write_joint_bag",
    "write_qualisys_tsv",
]
