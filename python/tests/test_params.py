"""The module's keyword defaults and docstrings against the parameter table (trilevel/params_table.hpp,
exposed as trilevel._trilevel._parameter_table()), the one the CLI's options and --help come from
(tests/test_params_table.cpp checks the CLI side)."""
import unittest

import numpy as np

import trilevel
from trilevel import _trilevel
from test_stubs import module_signature

# The keywords that are no Params field.
PYTHON_ONLY = {"positions", "attributes", "return_levels", "device", "reconstructor"}


def same(table_default, module_text):
    module = None if module_text is None else eval(module_text)  # literals: 'adaptive', 4.0, None, False, 0
    if isinstance(table_default, float):  # the module's floats are float32 (0.32 shows as 0.3199999928474426)
        return isinstance(module, float) and np.float32(module) == np.float32(table_default)
    return module == table_default and type(module) is type(table_default)


def flat(text):
    return " ".join(text.split())


class ParameterTableTest(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        cls.table = {e["python"]: e for e in _trilevel._parameter_table()}

    def test_the_table_lists_the_fields_once(self):
        rows = _trilevel._parameter_table()
        self.assertEqual(len(rows), 16)
        self.assertEqual(len({e["field"] for e in rows}), 16)
        self.assertEqual([e["python"] for e in rows if e["required"]], ["particle_radius"])

    def check(self, what, obj, name, expect_all, doc=None):
        """The keywords of obj's signature that are Params fields take the table's defaults, and `doc`
        (obj's docstring unless given) has the table's line for each."""
        params = module_signature(obj, name)
        doc = obj.__doc__ if doc is None else doc
        seen = set()
        for param, _, default in params:
            if param in PYTHON_ONLY:
                continue
            self.assertIn(param, self.table, f"{what}: keyword {param} is not in the parameter table")
            entry = self.table[param]
            seen.add(param)
            if entry["required"]:
                self.assertIsNone(default, f"{what}: {param} is required")
            else:
                self.assertTrue(same(entry["default"], default),
                                f"{what}: default of {param}: module {default}, table {entry['default']!r}")
            # The docstring's line for the keyword is the table's help, then the default.
            self.assertIn(flat(param + ": " + entry["help"] + "."), flat(doc), what)
        if expect_all:
            self.assertEqual(seen, set(self.table), what)
        return seen

    def test_reconstruct_takes_every_parameter_with_the_table_default(self):
        self.check("reconstruct", _trilevel.reconstruct, "reconstruct", True)
        self.check("Reconstructor.reconstruct", vars(_trilevel.Reconstructor)["reconstruct"], "reconstruct", True)

    def test_frame_pipeline_keywords_take_the_table_defaults(self):
        init = _trilevel.FramePipeline.__init__
        seen = self.check("FramePipeline", init, "__init__", False, _trilevel.FramePipeline.__doc__)
        self.assertGreaterEqual(len(seen), 10)

    def test_the_dask_command_line_takes_its_options_from_the_table(self):
        try:
            from trilevel import dask
        except ImportError as e:  # dask.distributed is optional (Debian python3-distributed)
            self.skipTest(f"trilevel.dask needs dask.distributed: {e}")
        actions = {a.dest: a for a in dask._parser()._actions}
        for keyword in dask._OPTIONS:
            entry = self.table[keyword]
            action = actions[keyword]
            self.assertEqual(action.option_strings, entry["cli"].split(","), keyword)
            self.assertIsNone(action.default, keyword)  # not given: the module's default, Params{}'s
            self.assertTrue(action.help.startswith(entry["help"] + " (default: "), keyword)

    def test_the_library_applies_the_defaults(self):
        """A reconstruction with no keywords reports the table's defaults (the placeholders, 0 for the
        calibrated threshold, report what they stand for)."""
        r = 0.05
        _, _, stats = trilevel.reconstruct(trilevel.generate_scene("sphere", r), r)
        reported = stats["parameters"]
        compared = 0
        for entry in self.table.values():
            field = entry["field"]
            if field not in reported or entry["required"] or entry["default_means"]:
                continue
            expected = entry["default"]
            if field == "normals":
                expected = "none" if expected is None else expected
            if isinstance(expected, float):
                self.assertEqual(np.float32(reported[field]), np.float32(expected), field)
            else:
                self.assertEqual(reported[field], expected, field)
            compared += 1
        self.assertGreaterEqual(compared, 12)
        self.assertEqual(np.float32(reported["curvature_threshold"]), np.float32(trilevel.default_curvature_threshold()))


if __name__ == "__main__":
    unittest.main()
