"""Users, login, API tokens, roles and sharing (schemas, repository, service, router)."""
