"""The tests' record suite: :mod:`pycolfrag.ground_motion.demo_records` (closed-form sines and pulses, PEER layout)."""
from pycolfrag.ground_motion.demo_records import RECORDS, pulse, sine, write_at2, write_suite  # noqa: F401
