"""The operators as torch.autograd Functions: the backward of a blur is its
exact transpose, so a loss through B trains or reconstructs through B^T.

    from petblur.torch import blur
    y = blur(B, x)        # differentiable in x
"""

import torch


class BlurFunction(torch.autograd.Function):
    """y = op(x); dL/dx = op.adjoint(dL/dy). For a FramesOperator given one
    activity, the adjoint sums the frames, as the chain rule asks."""

    @staticmethod
    def forward(ctx, x, op):
        ctx.op = op
        ctx.one_volume = x.dim() == 3
        return op.apply(x)

    @staticmethod
    def backward(ctx, grad):
        op = ctx.op
        if hasattr(op, "frames"):
            return op.adjoint(grad.contiguous(), sum=ctx.one_volume), None
        return op.adjoint(grad.contiguous()), None


def blur(op, x):
    """op(x), differentiable in x."""
    return BlurFunction.apply(x, op)
