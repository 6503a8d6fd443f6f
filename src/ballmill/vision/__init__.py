"""High-speed video of the MM400 jar: a renderer of synthetic videos and an OpenCV ball tracker."""
