"""deskarm's application layer: CLI, window, workers, headless runner.

OpenCV's worker threads busy-wait for the next parallel job after each one (OpenCV 5's default
``OPENCV_THREAD_POOL_ACTIVE_WAIT_WORKER``); at 30 frames a second of small jobs that spinning
cost ~10 % of a core while following a marker (measured with per-thread CPU times). Workers
that sleep at once cost the pipeline ~0.05 ms a frame. Set before cv2 is first imported; a
user's own setting wins.
"""
import os

os.environ.setdefault("OPENCV_THREAD_POOL_ACTIVE_WAIT_WORKER", "0")
