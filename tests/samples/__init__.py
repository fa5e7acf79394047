"""Extensions written as a user would, for the tests: good ones and broken ones (tests/test_extensions.py)."""
