"""The thesis's chapter 5 experiment: worlds, the simulated LMS200 and Pioneer 3-DX, ground truth,
UMBmark (Appendix I), the pose-error model and the demo."""
