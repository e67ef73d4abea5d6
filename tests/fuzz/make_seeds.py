#!/usr/bin/env python3
"""Writes the hand-made seeds of the fuzz corpus (tests/fuzz/corpus/*/seed-*).

Not run by the tests: the seeds are checked in. The rest of each corpus is
what libFuzzer found from them, minimized with -merge=1 (README.md).
Usage: python3 tests/fuzz/make_seeds.py [CORPUS_DIR]
"""
import os
import sqlite3
import struct
import sys

CORPUS = sys.argv[1] if len(sys.argv) > 1 else os.path.join(
    os.path.dirname(os.path.abspath(__file__)), "corpus")
K = 2147483647  # COLMAP's pair id factor.

# COLMAP 3.8's schema (as hisfm/io/database.cc's ColmapSchemaStatements).
SCHEMA = """
CREATE TABLE cameras (camera_id INTEGER PRIMARY KEY AUTOINCREMENT NOT NULL,
  model INTEGER NOT NULL, width INTEGER NOT NULL, height INTEGER NOT NULL,
  params BLOB, prior_focal_length INTEGER NOT NULL);
CREATE TABLE images (image_id INTEGER PRIMARY KEY AUTOINCREMENT NOT NULL,
  name TEXT NOT NULL UNIQUE, camera_id INTEGER NOT NULL, prior_qw REAL,
  prior_qx REAL, prior_qy REAL, prior_qz REAL, prior_tx REAL, prior_ty REAL,
  prior_tz REAL, CONSTRAINT image_id_check CHECK(image_id >= 0 and
  image_id < 2147483647), FOREIGN KEY(camera_id) REFERENCES
  cameras(camera_id));
CREATE UNIQUE INDEX index_name ON images(name);
CREATE TABLE keypoints (image_id INTEGER PRIMARY KEY NOT NULL,
  rows INTEGER NOT NULL, cols INTEGER NOT NULL, data BLOB,
  FOREIGN KEY(image_id) REFERENCES images(image_id) ON DELETE CASCADE);
CREATE TABLE descriptors (image_id INTEGER PRIMARY KEY NOT NULL,
  rows INTEGER NOT NULL, cols INTEGER NOT NULL, data BLOB,
  FOREIGN KEY(image_id) REFERENCES images(image_id) ON DELETE CASCADE);
CREATE TABLE matches (pair_id INTEGER PRIMARY KEY NOT NULL,
  rows INTEGER NOT NULL, cols INTEGER NOT NULL, data BLOB);
CREATE TABLE two_view_geometries (pair_id INTEGER PRIMARY KEY NOT NULL,
  rows INTEGER NOT NULL, cols INTEGER NOT NULL, data BLOB,
  config INTEGER NOT NULL, F BLOB, E BLOB, H BLOB, qvec BLOB, tvec BLOB);
"""


def write(target, name, data):
    folder = os.path.join(CORPUS, target)
    os.makedirs(folder, exist_ok=True)
    with open(os.path.join(folder, name), "wb") as f:
        f.write(data)


def doubles(*v):
    return struct.pack("<%dd" % len(v), *v)


def database_file(name, keypoint_cols=2, mutate=None):
    path = "/tmp/hisfm-seed.db"
    if os.path.exists(path):
        os.remove(path)
    db = sqlite3.connect(path)
    db.execute("PRAGMA page_size=512")
    db.executescript(SCHEMA)
    db.execute("INSERT INTO cameras VALUES (1, 2, 640, 480, ?, 1)",
               (doubles(500, 320, 240, 0.01),))
    for i in (1, 2, 3):
        db.execute("INSERT INTO images (image_id, name, camera_id) "
                   "VALUES (?, ?, 1)", (i, "img%d.jpg" % i))
        kp = struct.pack("<%df" % (4 * keypoint_cols),
                         *[float(10 * i + k) for k in range(4 * keypoint_cols)])
        db.execute("INSERT INTO keypoints VALUES (?, 4, ?, ?)",
                   (i, keypoint_cols, kp))
        db.execute("INSERT INTO descriptors VALUES (?, 4, 128, ?)",
                   (i, bytes(range(128)) * 4))
    for a, b in ((1, 2), (1, 3), (2, 3)):
        m = struct.pack("<4I", 0, 1, 2, 3)
        db.execute("INSERT INTO matches VALUES (?, 2, 2, ?)", (K * a + b, m))
        db.execute("INSERT INTO two_view_geometries VALUES "
                   "(?, 2, 2, ?, 2, ?, ?, ?, ?, ?)",
                   (K * a + b, m, doubles(*range(9)), doubles(*range(9)),
                    doubles(*range(9)), doubles(1, 0, 0, 0),
                    doubles(0, 0, 1)))
    if mutate:
        db.execute(mutate)
    db.commit()
    db.execute("VACUUM")
    db.close()
    with open(path, "rb") as f:
        write("database_file_fuzzer", name, f.read())
    os.remove(path)


class Encoder:
    """Bytes that database_fuzzer.cc's FuzzInput reads back as the values."""

    def __init__(self):
        self.out = bytearray()

    def byte(self, b):
        self.out.append(b)

    def pick(self, values, value):
        self.byte(values.index(value))

    def int_value(self):  # BindInt's flag: an integer.
        self.byte(3)

    def blob_value(self):  # BindBlob's flag: a blob.
        self.byte(3)


SMALL_IDS = [1, 2, 3, 4, 0, 5, K - 1, K, -1]


def structured_database():
    e = Encoder()
    e.byte(0)  # COLMAP's schema.
    # Camera 1: SIMPLE_PINHOLE 640 x 480, params (f, cx, cy).
    e.byte(0)
    e.pick([1, 2, 0, -1], 1); e.int_value()
    e.pick([0, 1, 2, 3, 4, 6, 10, 11, -1], 0); e.int_value()
    e.pick([640, 1, 0, -640], 640); e.int_value()
    e.pick([480, 1, 0, -480], 480); e.int_value()
    e.byte(1)  # Bool: the model's parameter count.
    e.byte(1)  # Blob of values.
    for v in (200, 100, 100):
        e.byte(4); e.byte(v)
    e.blob_value()
    e.byte(1); e.int_value()
    for image in (1, 2, 3):
        e.byte(1)
        e.pick(SMALL_IDS, image); e.int_value()
        e.byte(image - 1)  # Name a.jpg, b.jpg, c.jpg.
        e.byte(1)  # As text.
        e.pick([1, 2, 7], 1); e.int_value()
        # Keypoints: 3 rows x 2 cols.
        e.byte(2)
        e.pick(SMALL_IDS, image); e.int_value()
        e.pick([3, 5, 0, 1, 8, K], 3)
        e.pick([2, 4, 6, 3, 0, 128], 2)
        e.int_value(); e.int_value()
        e.byte(1)  # n, not n - 1.
        e.byte(1)
        for k in range(6):
            e.byte(4); e.byte(10 * image + k)
        e.blob_value()
    for a, b in ((1, 2), (2, 3)):
        e.byte(5)  # two_view_geometries.
        e.pick(SMALL_IDS, a); e.pick(SMALL_IDS, b); e.byte(2)
        e.int_value()
        e.pick([2, 4, 0, 1, 7, K], 2)
        e.pick([2, 3, 0, 1], 2)
        e.int_value(); e.int_value()
        e.byte(1); e.byte(1)
        for idx in (0, 1, 2, 1):
            e.pick([0, 1, 2, 3, 4, 7, K], idx)
        e.blob_value()
        e.pick([2, 3, 0, 1, 4, 5, 6, 7, 8, 9, 99, -1], 2); e.int_value()
        for size in (9, 9, 9, 4, 3):
            e.byte(1); e.byte(1); e.byte(1)
            for k in range(size):
                e.byte(4); e.byte(k)
            e.blob_value()
    write("database_fuzzer", "seed-valid", bytes(e.out))
    write("database_fuzzer", "seed-empty", bytes([0]))
    write("database_fuzzer", "seed-loose-schema", bytes([7]) + bytes(e.out[1:]))


def framed(*files):
    out = b""
    for f in files[:-1]:
        out += struct.pack("<I", len(f)) + f
    return out + files[-1]


def models():
    cameras = struct.pack("<Q", 1) + struct.pack("<IiQQ", 1, 0, 640, 480) + \
        doubles(500, 320, 240)
    images = struct.pack("<Q", 2)
    for image in (1, 2):
        images += struct.pack("<I", image) + doubles(1, 0, 0, 0, image, 0, 0)
        images += struct.pack("<I", 1) + b"img%d.jpg\0" % image
        images += struct.pack("<Q", 2)
        for k in range(2):
            images += doubles(100 + k, 200) + struct.pack("<Q", 10 + k)
    points = struct.pack("<Q", 2)
    for k in range(2):
        points += struct.pack("<Q", 10 + k) + doubles(0, 0, 5 + k)
        points += bytes([255, 0, 0]) + doubles(0.5) + struct.pack("<Q", 2)
        points += struct.pack("<II", 1, k) + struct.pack("<II", 2, k)
    write("model_binary_fuzzer", "seed-valid", framed(cameras, images, points))
    write("model_binary_fuzzer", "seed-empty",
          framed(struct.pack("<Q", 0), struct.pack("<Q", 0),
                 struct.pack("<Q", 0)))
    cameras_txt = b"# Camera list\n1 SIMPLE_RADIAL 640 480 500 320 240 0.01\n"
    images_txt = b"# Image list\n"
    for image in (1, 2):
        images_txt += b"%d 1 0 0 0 %d 0 0 1 img%d.jpg\n" % (image, image, image)
        images_txt += b"100 200 10 101 200 11 50 60 -1\n"
    points_txt = b"# 3D points\n"
    for k in range(2):
        points_txt += b"%d 0 0 %d 255 0 0 0.5 1 %d 2 %d\n" % (10 + k, 5 + k, k, k)
    write("model_text_fuzzer", "seed-valid",
          framed(cameras_txt, images_txt, points_txt))
    write("model_text_fuzzer", "seed-empty", framed(b"", b"", b""))


database_file("seed-valid")
database_file("seed-cols6", keypoint_cols=6)
database_file("seed-huge-rows",
              mutate="UPDATE keypoints SET rows = 2147483647 WHERE image_id = 2")
database_file("seed-empty", mutate="DELETE FROM cameras")
structured_database()
models()
