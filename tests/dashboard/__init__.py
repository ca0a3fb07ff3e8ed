"""Tests of the dashboard: feed logic, REST API, and the page in chromium."""
