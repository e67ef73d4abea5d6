#!/usr/bin/env python3
"""Tests of scripts/long_functions.py on a small C++ file (run by ctest)."""
import os
import subprocess
import sys
import tempfile
import unittest

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import long_functions  # noqa: E402

SOURCE = '''#include "x.h"

namespace hisfm {
namespace {

// A comment with a brace { that is not code.
int Short(int a) {
  return a + 1;
}

struct Local {
  void Method() const {
    const char* s = "} not a brace {";
    if (s) {
      return;
    }
  }
};

}  // namespace

std::vector<int> Long(const std::vector<int>& in,
                      int k) {
  std::vector<int> out;
  for (int x : in) {
    out.push_back([&] { return x * k; }());
  }
  return out;
}

const int kTable[] = {1, 2, 3};

}  // namespace hisfm
'''


class LongFunctionsTest(unittest.TestCase):
    def setUp(self):
        self.dir = tempfile.TemporaryDirectory()
        self.path = os.path.join(self.dir.name, 'x.cc')
        with open(self.path, 'w') as f:
            f.write(SOURCE)

    def tearDown(self):
        self.dir.cleanup()

    def test_finds_each_function_with_its_lines(self):
        found = list(long_functions.functions(self.path))
        self.assertEqual(found, [('Short', 7, 3), ('Method', 12, 6),
                                 ('Long', 22, 8)])

    def test_lists_the_functions_over_the_limit(self):
        out = subprocess.run(
            [sys.executable, long_functions.__file__, '--limit', '5',
             self.path], check=True, capture_output=True, text=True).stdout
        lines = out.strip().split('\n')
        self.assertEqual(len(lines), 3)
        self.assertTrue(lines[0].split()[0] == '8' and
                        lines[0].endswith('x.cc:22 Long'))
        self.assertTrue(lines[1].endswith('x.cc:12 Method'))
        self.assertEqual(lines[2], '2')


if __name__ == '__main__':
    unittest.main()
