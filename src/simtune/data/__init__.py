"""Recordings (motion capture, joint logs, LeRobot datasets): loading, writing, and per-task reference data.

Formats are described in docs/recordings.md.
"""

from simtune.data.csvformat import write_csv
from simtune.data.fingerprint import data_fingerprint, fingerprint_changes, task_files
from simtune.data.lerobot import LeRobotReading, read_lerobot_dataset, write_lerobot_dataset
from simtune.data.loaders import RECORDING_SUFFIXES, load_recording, load_recordings
from simtune.data.qualisys import write_qualisys_tsv
from simtune.data.recording import QRG2019_BODIES, Recording
from simtune.data.rosbag import read_joint_bag, write_joint_bag
from simtune.data.task import REPEATS, TaskData, check_repeats, load_task_data, resample

__all__ = [
    "QRG2019_BODIES",
    "RECORDING_SUFFIXES",
    "REPEATS",
    "LeRobotReading",
    "Recording",
    "TaskData",
    "check_repeats",
    "data_fingerprint",
    "fingerprint_changes",
    "load_recording",
    "load_recordings",
    "load_task_data",
    "read_joint_bag",
    "read_lerobot_dataset",
    "resample",
    "task_files",
    "write_csv",
    "write_joint_bag",
    "write_lerobot_dataset",
    "write_qualisys_tsv",
]
