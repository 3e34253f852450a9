"""Test-only patch: decoder_nr gives (slope_x, slope_y, roughness); normals = normalize(-sx, -sy, 1)."""
import torch
import svbrdf.trainer.models as M
from svbrdf.runtime.maps import MAP_NAMES

_init = M.Generator.__init__
def __init__(self, cfg=None):
    _init(self, cfg)
    ch, gdim = M._unet_channels(self.cfg), M._ch(128, self.cfg.width)
    self.decoder_nr = M.UNetDecoder(ch, gdim, 3)
    self.slope_offset = torch.nn.Parameter(torch.zeros(2))

def decode(self, latent, maps=MAP_NAMES, size=None):
    skips = latent[0]
    h, w = size if size is not None else skips[0].shape[-2:]
    out = {}
    y = self._decoded("decoder_nr", latent)[..., :h, :w].float()
    s = y[:, 0:2] * 0.5
    n = torch.cat([-s[:, 0:1], -s[:, 1:2], torch.ones_like(s[:, :1])], 1)
    out["normal"] = n * torch.rsqrt((n * n).sum(1, keepdim=True))
    out["roughness"] = (torch.tanh(y[:, 2:3] + self.out_offset[1]) + 1) * 0.5
    z = self._unit(self._decoded("decoder_ds", latent) + self.out_offset[2:6].view(1, 4, 1, 1))[..., :h, :w]
    out["diffuse"], out["specular"] = z[:, 0:3], z[:, 3:4]
    return {k: out[k] for k in MAP_NAMES if k in set(maps)}

M.Generator.__init__ = __init__
M.Generator.decode = decode
