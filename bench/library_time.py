"""The library's own device time of a call, without torch: for the benches
that time petblur on any device (CUDA, PoCL) from its own events."""

import statistics


def device_ms(op, call, n=5):
    """The library's own device time of op's last call, median of n calls:
    (kernels ms, the input's copy into the texture ms)."""
    kernel, inputs = [], []
    for _ in range(n):
        call()
        total, inp = op.last_device_ms()
        kernel.append(total - inp)
        inputs.append(inp)
    return statistics.median(kernel), statistics.median(inputs)
