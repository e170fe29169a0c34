#!/usr/bin/env python3
"""Golden values from PyTorch for defender-nn's tests.

Writes crates/defender-nn/tests/data/golden.json and golden_sequential.safetensors:
- forward/backward of small nn.Sequential MLPs (ReLU/identity and tanh/tanh) under an MSE loss:
  parameters, input, target, output, loss, parameter gradients and input gradient;
- torch.optim.Adam on such a network over several steps with changing gradients and a
  learning-rate change, recording parameters and moments after every step;
- Polyak averaging as Stable-Baselines3 does it;
- the state_dict of the first network written as safetensors (by hand: 8-byte header length,
  JSON header, little-endian data) under PyTorch's own key names.

Run: .deps/tools-venv/bin/python tools/golden/nn_golden.py
"""
import json
import struct
from pathlib import Path

import torch

OUT = Path(__file__).resolve().parents[2] / "crates" / "defender-nn" / "tests" / "data"
ACT = {"relu": torch.nn.ReLU, "tanh": torch.nn.Tanh, "identity": torch.nn.Identity}


def sequential(widths, hidden, output):
    layers = []
    for i, (a, b) in enumerate(zip(widths[:-1], widths[1:])):
        layers.append(torch.nn.Linear(a, b))
        layers.append(ACT[hidden if i < len(widths) - 2 else output]())
    return torch.nn.Sequential(*layers)


def flat(t):
    return t.detach().reshape(-1).tolist()


def tensors(named):
    return {k: {"shape": list(v.shape), "values": flat(v)} for k, v in named}


def fwd_bwd_case(seed, widths, hidden, output, batch):
    torch.manual_seed(seed)
    net = sequential(widths, hidden, output)
    x = torch.randn(batch, widths[0], requires_grad=True)
    target = torch.randn(batch, widths[-1])
    out = net(x)
    loss = torch.nn.functional.mse_loss(out, target)
    loss.backward()
    return net, {
        "widths": widths,
        "hidden": hidden,
        "output": output,
        "params": tensors(net.state_dict().items()),
        "input": {"shape": list(x.shape), "values": flat(x)},
        "target": {"shape": list(target.shape), "values": flat(target)},
        "output_values": flat(out),
        "loss": loss.item(),
        "grads": tensors((k, p.grad) for k, p in net.named_parameters()),
        "input_grad": flat(x.grad),
    }


def adam_case(seed):
    torch.manual_seed(seed)
    widths = [4, 6, 2]
    net = sequential(widths, "relu", "identity")
    initial = tensors(net.state_dict().items())
    opt = torch.optim.Adam(net.parameters(), lr=1e-2, betas=(0.9, 0.999), eps=1e-8)
    steps = []
    for step in range(5):
        if step == 3:
            for g in opt.param_groups:
                g["lr"] = 3e-3
        opt.zero_grad()
        x = torch.randn(8, widths[0])
        target = torch.randn(8, widths[-1])
        loss = torch.nn.functional.mse_loss(net(x), target)
        loss.backward()
        grads = tensors((k, p.grad) for k, p in net.named_parameters())
        opt.step()
        steps.append({
            "lr": opt.param_groups[0]["lr"],
            "grads": grads,
            "params": tensors(net.state_dict().items()),
            "exp_avg": tensors((k, opt.state[p]["exp_avg"]) for k, p in net.named_parameters()),
            "exp_avg_sq": tensors((k, opt.state[p]["exp_avg_sq"]) for k, p in net.named_parameters()),
        })
    return {"widths": widths, "initial": initial, "steps": steps}


def polyak_case(seed):
    torch.manual_seed(seed)
    src, tgt = torch.randn(50), torch.randn(50)
    before = tgt.clone()
    tau = 0.005
    # stable_baselines3.common.utils.polyak_update
    torch.mul(tgt, 1 - tau, out=tgt)
    torch.add(tgt, src, alpha=tau, out=tgt)
    return {"tau": tau, "source": flat(src), "target": flat(before), "result": flat(tgt)}


def write_safetensors(path, state_dict):
    header, blobs, offset = {}, [], 0
    for name, t in state_dict.items():
        data = t.detach().contiguous().to(torch.float32).numpy().astype("<f4").tobytes()
        header[name] = {"dtype": "F32", "shape": list(t.shape), "data_offsets": [offset, offset + len(data)]}
        blobs.append(data)
        offset += len(data)
    header["__metadata__"] = {"format": "pt"}
    h = json.dumps(header, separators=(",", ":")).encode()
    h += b" " * (-len(h) % 8)
    path.write_bytes(struct.pack("<Q", len(h)) + h + b"".join(blobs))


def main():
    OUT.mkdir(parents=True, exist_ok=True)
    net, relu = fwd_bwd_case(0, [5, 8, 7, 3], "relu", "identity", 4)
    _, tanh = fwd_bwd_case(1, [3, 6, 2], "tanh", "tanh", 5)
    golden = {
        "torch_version": torch.__version__,
        "mlp": [relu, tanh],
        "adam": adam_case(2),
        "polyak": polyak_case(3),
    }
    (OUT / "golden.json").write_text(json.dumps(golden, indent=1) + "\n")
    write_safetensors(OUT / "golden_sequential.safetensors", net.state_dict())
    print(f"wrote {OUT}/golden.json and golden_sequential.safetensors (torch {torch.__version__})")


if __name__ == "__main__":
    main()
