//! `.pth` / `.pt` files written by `torch.save` (to be written).
