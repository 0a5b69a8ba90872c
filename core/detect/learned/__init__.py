"""The detector deskarm ships: a small network trained on renders of the simulated desk.

``evaluation`` scores detections (per-class AP, mAP@0.5; numpy only). ``model`` holds the network,
its training and its ONNX export and needs torch (the optional ``train`` extra), so nothing imports
it but ``deskarm train-detector`` and the torch tests. At run time the shipped
``resources/models/desk_objects.onnx`` is read by ``core.detect.onnx_yolo.OnnxYoloDetector``
(``make_detector("desk")``) — no torch needed.
"""
