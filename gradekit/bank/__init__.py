"""The problem bank: YAML problem definitions, validated into frozen records."""
