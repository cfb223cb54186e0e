"""Python side of rrr_graphslam: pose-graph files, outlier injection, evaluation, replay."""
