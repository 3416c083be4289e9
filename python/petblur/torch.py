"""The operators as torch.autograd Functions: the backward of a blur is its
exact transpose, so a loss through B trains or reconstructs through B^T; and
the blur as a function of its motion's samples, for motion estimated by
gradient descent.

    from petblur.torch import blur, blur_posed
    y = blur(B, x)              # differentiable in x
    y = blur_posed(B, x, xi)    # in x and in xi (K, 6), each sample's pose
"""

import torch

from . import pose


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


class PosedBlurFunction(torch.autograd.Function):
    """y = B(xi) x: the BlurOperator op with each sample k of its motion moved
    by xi[k] = (vx, vy, vz, wx, wy, wz) (mm, radians) on the object's side,
    T_k -> T_k G(xi_k)^-1 (petblur.pose). dL/dx = B(xi)^T dL/dy, exact;
    dL/dxi_k = <dL/dy, d(B(xi) x)/dxi_k>, the continuous model's derivative
    (petblur.pose.vjp; docs/python.md, "Pose gradients")."""

    @staticmethod
    def forward(ctx, x, xi, op, nodes):
        xi_np = xi.detach().to("cpu", torch.float64).numpy()
        posed = pose.posed_operator(op, xi_np)
        ctx.save_for_backward(x)
        ctx.op, ctx.posed, ctx.xi, ctx.nodes = op, posed, xi_np, nodes
        ctx.xi_like = (xi.dtype, xi.device)
        return posed.apply(x)

    @staticmethod
    def backward(ctx, grad):
        (x,) = ctx.saved_tensors
        grad = grad.contiguous()
        gx = gxi = None
        if ctx.needs_input_grad[0]:
            gx = ctx.posed.adjoint(grad)
        if ctx.needs_input_grad[1]:
            g = pose.vjp(ctx.op, x.detach(), grad, ctx.xi, ctx.nodes)
            gxi = torch.as_tensor(g, dtype=ctx.xi_like[0], device=ctx.xi_like[1])
        return gx, gxi, None, None


def blur_posed(op, x, xi, nodes=2):
    """B(xi) x, differentiable in x (the exact transpose) and in xi, a (K, 6)
    tensor, one row per sample of op's motion (K = len(op.motion)): each
    sample's pose composed with G(xi_k)^-1 on the object's side, G(xi) p =
    R(w) (p - c) + c + v about the motion's centre c, in the motion's
    coordinates (world mm with affine=, else the grid's). op is a
    petblur.BlurOperator; nodes, the Gauss-Legendre nodes per tracked
    interval of the time quadrature (petblur.pose)."""
    from .errors import ArgumentError
    from .motion import Motion
    if not isinstance(getattr(op, "motion", None), Motion):
        raise ArgumentError("blur_posed moves the poses of a rigid Motion; a FieldMotion's operator has none: use "
                            "blur(op, x), differentiable in x")
    return PosedBlurFunction.apply(x, xi, op, nodes)
