"""The pose-uncertainty model an ROP run uses, by the name in ``RopConfig.cov``: first-order
propagation (:class:`vo.rop.uncertainty.PropagatedCovariance`) or the replicate-chain bootstrap
(:class:`vo.rop.chain_bootstrap.ChainBootstrap`). Kept apart from both so neither imports the other's
dependants."""
from __future__ import annotations

from vo.rop.chain_bootstrap import ChainBootstrap
from vo.rop.uncertainty import PropagatedCovariance, UncertaintyModel


def make_uncertainty(config, adjustment_config, focal: float) -> UncertaintyModel:
    """The model named by ``config.cov`` (:class:`~vo.rop.rop_config.RopConfig`)."""
    if config.cov == "chain_bootstrap":
        return ChainBootstrap(config, adjustment_config, focal)
    return PropagatedCovariance()
