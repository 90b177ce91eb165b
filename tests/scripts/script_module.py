"""The project's scripts without a .py suffix (scripts/compare-barriers, scripts/extractor-cost) loaded as modules,
so that tests call their functions on known inputs."""
import importlib.machinery
import importlib.util
import os

SCRIPTS = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "..", "scripts")


def load_script(file_name, module_name):
    """scripts/<file_name> as a module named module_name."""
    loader = importlib.machinery.SourceFileLoader(module_name, os.path.join(SCRIPTS, file_name))
    spec = importlib.util.spec_from_loader(module_name, loader)
    module = importlib.util.module_from_spec(spec)
    loader.exec_module(module)
    return module
