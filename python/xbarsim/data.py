"""Training and test data: CIFAR-10 in its binary format (data_batch_*.bin, test_batch.bin:
records of one label byte and 3 x 32 x 32 pixel bytes, channel-major), preprocessed as a model's
metadata says, with the usual augmentation (4-pixel padded random crop, horizontal flip).

    import xbarsim.data
    train = xbarsim.data.Cifar10("../shared/data/cifar10", train=True, preprocessing=model.preprocessing)
    for x, y in train.batches(128, epoch=0):   # shuffled and augmented from (seed, epoch)
        ...
"""
import glob
import os

import numpy as np
import torch

from . import _core

__all__ = ["Cifar10", "read_cifar10"]


def read_cifar10(paths):
    """(images uint8 N x 3 x 32 x 32, labels int64 N) from CIFAR-10 binary files, in order, read by
    eval's own loader (xbarsim._core.read_cifar10): the images eval reads from the same files.
    ValueError naming a file that cannot be opened, is not a whole number of records or holds a
    label above 9."""
    read = [_core.read_cifar10(os.fspath(path)) for path in paths]
    if not read:
        raise ValueError("read_cifar10 needs at least one file")
    return np.concatenate([r[0] for r in read]), np.concatenate([r[1] for r in read])


class Cifar10:
    """CIFAR-10 from `root`: with train=True its data_batch_*.bin files (the shared data has two,
    20 000 images; a full download five), else test_batch.bin; or `files`, a list of paths.
    `preprocessing`: (scale, mean, std) as OnnxModule.preprocessing (x = (pixel * scale -
    mean[c]) / std[c]). `limit`: the first `limit` images only. `augment` (default: train):
    random crop of the image padded by 4 zero pixels (in pixel space, before normalisation) and a
    horizontal flip, each image's from (seed, epoch, index)."""

    def __init__(self, root=None, train=True, preprocessing=(1 / 255, [0.0], [1.0]), files=None, limit=None,
                 augment=None, seed=0):
        if files is None:
            if root is None:
                raise ValueError("Cifar10 needs root= (a directory) or files=")
            root = os.fspath(root)
            if not os.path.isdir(root):
                raise ValueError(f"{root}: no such directory")
            pattern = "data_batch_*.bin" if train else "test_batch.bin"
            files = sorted(glob.glob(os.path.join(root, pattern)))
            if not files:
                raise ValueError(f"{root}: no CIFAR-10 {'training' if train else 'test'} files ({pattern}) in it")
        self.files = [os.fspath(f) for f in files]
        self.images, self.labels = read_cifar10(self.files)
        if limit is not None:
            if limit < 1:
                raise ValueError("limit must be >= 1")
            self.images, self.labels = self.images[:limit], self.labels[:limit]
        scale, mean, std = preprocessing
        self.scale = float(scale)
        self.mean = torch.tensor(mean, dtype=torch.float32).reshape(1, -1, 1, 1)
        self.std = torch.tensor(std, dtype=torch.float32).reshape(1, -1, 1, 1)
        self.augment = train if augment is None else bool(augment)
        self.seed = int(seed)

    def __len__(self):
        return len(self.labels)

    def preprocess(self, pixels):
        """uint8 N x 3 x 32 x 32 -> float32 model inputs."""
        x = torch.from_numpy(np.ascontiguousarray(pixels)).float() * self.scale
        return (x - self.mean) / self.std

    def batches(self, batch_size, epoch=0, shuffle=None):
        """(inputs, labels) batches over the whole set: shuffled (default: when training) and
        augmented from (seed, epoch); the last batch may be smaller."""
        n = len(self)
        shuffle = self.augment if shuffle is None else shuffle
        rng = np.random.default_rng([self.seed, epoch])
        order = rng.permutation(n) if shuffle else np.arange(n)
        for start in range(0, n, batch_size):
            idx = order[start:start + batch_size]
            pixels = self.images[idx]
            if self.augment:
                padded = np.zeros((len(idx), 3, 40, 40), dtype=np.uint8)
                padded[:, :, 4:36, 4:36] = pixels
                dy, dx = rng.integers(0, 9, size=(2, len(idx)))
                flip = rng.random(len(idx)) < 0.5
                out = np.empty_like(pixels)
                for k in range(len(idx)):
                    crop = padded[k, :, dy[k]:dy[k] + 32, dx[k]:dx[k] + 32]
                    out[k] = crop[:, :, ::-1] if flip[k] else crop
                pixels = out
            yield self.preprocess(pixels), torch.from_numpy(self.labels[idx])
